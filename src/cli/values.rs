//! Value parsers of the flags that hold a duration, a force, a distance or a count: a value that cannot be right
//! (zero starts, a negative duration) is refused by the parser, naming the flag of the command that was run.

/// A positive, finite number (durations, forces, distances, intervals).
pub(crate) fn positive(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a positive number, got {s}"))
    }
}

/// A finite number ≥ 0 (added latencies).
pub(crate) fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a number ≥ 0, got {s}"))
    }
}

/// A share in [0, 1) (a loss rate).
pub(crate) fn share(s: &str) -> Result<f64, String> {
    let v = non_negative(s)?;
    if v < 1.0 {
        Ok(v)
    } else {
        Err(format!("must be a share in [0, 1), got {s}"))
    }
}

/// A whole number of at least one (starts, runs, levels, counts).
pub(crate) fn at_least_one(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        Ok(_) => Err("must be at least 1".into()),
        Err(_) => Err(format!("`{s}` is not a whole number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_and_counts_must_be_positive() {
        assert_eq!(positive("2.5"), Ok(2.5));
        assert!(positive("-3").unwrap_err().contains("positive"));
        assert!(positive("0").is_err() && positive("inf").is_err() && positive("NaN").is_err());
        assert!(positive("ten").unwrap_err().contains("not a number"));
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(non_negative("-0.1").is_err());
        assert_eq!(share("0.05"), Ok(0.05));
        assert!(share("1").is_err() && share("-0.1").is_err());
        assert_eq!(at_least_one("3"), Ok(3));
        assert!(at_least_one("0").unwrap_err().contains("at least 1"));
        assert!(at_least_one("-1").is_err() && at_least_one("1.5").is_err());
    }
}
