//! MuJoCo's quasi-random numbers, as its own tools use them (testspeed's control noise).

/// The `index`-th element of the Halton sequence in base `base` (`mju_Halton`), in [0, 1).
pub fn halton(index: usize, base: usize) -> f64 {
    // SAFETY: a pure function of its two integers.
    unsafe { mujoco_sys::ffi::mju_Halton(index as i32, base as i32) }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_halton_sequence_in_base_two_halves_its_intervals() {
        let v: Vec<f64> = (1..5).map(|i| super::halton(i, 2)).collect();
        assert_eq!(v, [0.5, 0.25, 0.75, 0.125]);
    }
}
