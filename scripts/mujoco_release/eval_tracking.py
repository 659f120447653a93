#!/usr/bin/env python3
"""A second, independent evaluator of the tracking experiment (`topa eval tracking`) in MuJoCo's current release.

It uses only an ONNX policy exported with `topa export --motor-targets`, its metadata, the robot spec (TOML) and the
MJCF, loaded by the official `mujoco` Python bindings (not the repository's MuJoCo 2.2 and Rust bindings). The
observation and the control loop are written again from the documented layout (docs/deployment.md), so that a
policy whose numbers hold here does not hang on MuJoCo 2.2 details.

    bash scripts/mujoco_release/install.sh
    topa export --policy assets/policies/C/seed1.json --onnx out/C1.onnx --motor-targets
    .venv-mujoco-release/bin/python scripts/mujoco_release/eval_tracking.py \
        --onnx out/C1.onnx --spec assets/robots/topa_closed.toml --starts 1 --seconds 5 --json out/C1_mj.json

Protocol, as topa-eval/src/{tracking,runner,settings}.rs and topa-env/src/env/mod.rs run it (ideal sim2sim):
* physics at --timestep (0.0025 s) with the MJCF's integrator and solver settings; decimation = control period /
  timestep (8); the targets of each policy step are held for those physics steps (the MJCF's PD actuators);
* the six commands in COMMANDS' order; start s of command c is env s*6 + c, seeded as the Rust batch seeds it
  (seed 1, stream = env index): the stand keyframe, plus a base velocity drawn uniformly in ±0.1 on each of the
  six free-joint velocities (reproduced below bit for bit: ChaCha8 from rand_chacha 0.10, rand 0.10's sampling);
* the first observation carries the command that the reset drew at random (the Rust runner sets the zero
  command only after the reset wrote that observation); then 2 s (100 policy steps) on a zero command; the
  window's command is set before its first step, but that step still acts on the observation written before it
  (zero command), exactly as the runner does;
* after every window step: the fall test (torso origin below min_base_height, |roll| or |pitch| beyond max_tilt,
  or any contact between the ground and a body other than the feet), then the accumulators: `mae_whole` over the
  whole window (continuing after a fall, the paper-comparable numbers) and `mae_components` after a transient of
  min(2, seconds/2) s up to the fall (the `mae` of `topa eval tracking`);
* velocities in the torso frame (the full torso rotation, not a heading frame: state.rs rotates the free joint's
  world-frame linear velocity by the inverse of the torso quaternion; w_z is the body-frame angular velocity's z).

Not reproduced (see also the report in --json's "protocol_notes"): the gait metrics; the MuJoCo version itself
(2.2 vs this release: contact, solver and RK4 details differ, so trajectories are not expected to match bit for bit
and a chaotic gait diverges within seconds: compare means over starts, not single numbers).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import struct
import sys
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import mujoco
import onnxruntime as ort

# topa-eval/src/results.rs COMMANDS, in order.
COMMANDS = [
    ("walk_forward", (0.5, 0.0, 0.0)),
    ("walk_backward", (-0.35, 0.0, 0.0)),
    ("walk_right", (0.0, 0.5, 0.0)),
    ("walk_left", (0.0, -0.5, 0.0)),
    ("rotate_ccw", (0.0, 0.0, 1.0)),
    ("rotate_cw", (0.0, 0.0, -1.0)),
]
STAND_STILL_SHARE = 0.25  # tracking.rs
SETTLE_S = 2.0  # settings.rs EvalSettings::default().settle_s
SEED = 1  # settings.rs EvalSettings::default().seed (`topa eval --seed`)

# topa-env/src/config.rs defaults, used when the policy's own config cannot be read.
DEFAULT_TERMINATION = {"min_base_height": 0.3, "max_tilt": 1.0, "body_contact": True}
DEFAULT_COMMANDS = {
    "lin_vel_x": [-0.5, 0.7],
    "lin_vel_y": [-0.6, 0.6],
    "ang_vel_z": [-1.2, 1.2],
    "standing_share": 0.1,
    "turn_share": 0.0,
    "min_lin_norm": 0.05,
}

M64 = (1 << 64) - 1
M32 = (1 << 32) - 1


# ---------------------------------------------------------------------------------------------------------------
# The Rust env's random stream: rand_chacha 0.10 ChaCha8Rng::seed_from_u64(seed) with set_stream(index), sampled
# as rand 0.10 samples. Only the first draws of each env are used (the reset's base velocity and command).
# ---------------------------------------------------------------------------------------------------------------
def _rotl(x, n):
    return ((x << n) & M32) | (x >> (32 - n))


def _quarter(s, a, b, c, d):
    s[a] = (s[a] + s[b]) & M32
    s[d] = _rotl(s[d] ^ s[a], 16)
    s[c] = (s[c] + s[d]) & M32
    s[b] = _rotl(s[b] ^ s[c], 12)
    s[a] = (s[a] + s[b]) & M32
    s[d] = _rotl(s[d] ^ s[a], 8)
    s[c] = (s[c] + s[d]) & M32
    s[b] = _rotl(s[b] ^ s[c], 7)


def chacha_block(key_words, counter, nonce, rounds):
    """One ChaCha block (16 words) with a 64-bit counter (words 12-13) and a 64-bit nonce (words 14-15)."""
    init = [0x61707865, 0x3320646E, 0x79622D32, 0x6B206574, *key_words,
            counter & M32, counter >> 32, nonce & M32, nonce >> 32]
    s = list(init)
    for _ in range(rounds // 2):
        _quarter(s, 0, 4, 8, 12)
        _quarter(s, 1, 5, 9, 13)
        _quarter(s, 2, 6, 10, 14)
        _quarter(s, 3, 7, 11, 15)
        _quarter(s, 0, 5, 10, 15)
        _quarter(s, 1, 6, 11, 12)
        _quarter(s, 2, 7, 8, 13)
        _quarter(s, 3, 4, 9, 14)
    return [(x + y) & M32 for x, y in zip(s, init)]


class RustEnvRng:
    """ChaCha8Rng::seed_from_u64(seed); rng.set_stream(stream) — the stream of env `stream` of a Rust batch."""

    def __init__(self, seed: int, stream: int, rounds: int = 8, key_bytes: bytes | None = None):
        if key_bytes is None:  # rand_core 0.10 seed_from_u64: PCG32 fills the 32-byte seed
            state, out = seed & M64, b""
            for _ in range(8):
                state = (state * 0x5851F42D4C957F2D + 0xA17654E46FBE17F3) & M64
                xorshifted = (((state >> 18) ^ state) >> 27) & M32
                rot = state >> 59
                out += struct.pack("<I", ((xorshifted >> rot) | (xorshifted << ((32 - rot) & 31))) & M32)
            key_bytes = out
        self.key = list(struct.unpack("<8I", key_bytes))
        self.stream, self.rounds = stream, rounds
        self.words: list[int] = []
        self.block = 0

    def next_u32(self):
        if not self.words:
            self.words = chacha_block(self.key, self.block, self.stream, self.rounds)
            self.block += 1
        return self.words.pop(0)

    def next_u64(self):  # rand_core BlockRng::next_u64_from_u32: low word first (4-block buffer = same sequence)
        lo = self.next_u32()
        return lo | (self.next_u32() << 32)

    def random_f64(self):  # StandardUniform for f64: 53 high bits
        return (self.next_u64() >> 11) * (1.0 / (1 << 53))

    def range_f64(self, lo, hi):  # random_range(lo..hi) and (lo..=hi) for f64: UniformFloat::sample_single_inclusive
        bits = (self.next_u64() >> 12) | (1023 << 52)
        value1_2 = struct.unpack("<d", struct.pack("<Q", bits))[0]
        return (value1_2 - 1.0) * (hi - lo) + lo


def _self_test_chacha():
    # ChaCha20, zero key and nonce: test vector 1 of draft-nir-cfrg-chacha20-poly1305-04 (rand_chacha's own test).
    r = RustEnvRng(0, 0, rounds=20, key_bytes=bytes(32))
    got = [r.next_u32() for _ in range(4)]
    assert got == [0xADE0B876, 0x903DF1A0, 0xE56A5D40, 0x28BD8653], [hex(g) for g in got]
    # Test vector 5 (the nonce in the stream's high word), as rand_chacha's test_chacha_nonce sets it.
    r = RustEnvRng(0, 2 << 56, rounds=20, key_bytes=bytes(32))
    got = [r.next_u32() for _ in range(2)]
    assert got == [0x374DC6C2, 0x3736D58C], [hex(g) for g in got]


# ---------------------------------------------------------------------------------------------------------------
# Geometry
# ---------------------------------------------------------------------------------------------------------------
def quat_to_mat(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def euler_rpy(r):
    """nalgebra's Rotation3::euler_angles: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    if abs(r[2, 0]) < 1.0:
        pitch = -math.asin(r[2, 0])
        c = math.cos(pitch)
        return math.atan2(r[2, 1] / c, r[2, 2] / c), pitch, math.atan2(r[1, 0] / c, r[0, 0] / c)
    if r[2, 0] <= -1.0:
        return math.atan2(r[0, 1], r[0, 2]), math.pi / 2, 0.0
    return -math.atan2(-r[0, 1], -r[0, 2]), -math.pi / 2, 0.0


# ---------------------------------------------------------------------------------------------------------------
# The robot
# ---------------------------------------------------------------------------------------------------------------
class Robot:
    def __init__(self, spec_path: Path, meta: dict, timestep: float | None):
        with open(spec_path, "rb") as f:
            self.spec = tomllib.load(f)
        mjcf = (spec_path.parent / self.spec["mjcf"]).resolve()
        self.model = mujoco.MjModel.from_xml_path(str(mjcf))  # <include>s resolve relative to the file
        self.mjcf = mjcf
        m = self.model
        self.mjcf_timestep = float(m.opt.timestep)
        if timestep is not None:
            m.opt.timestep = timestep
        self.data = mujoco.MjData(m)
        name = lambda t, n: mujoco.mj_name2id(m, t, n)  # noqa: E731

        def must(t, n):
            i = name(t, n)
            if i < 0:
                raise SystemExit(f"{spec_path}: '{n}' is not in {mjcf}")
            return i

        J, B, A, G, K = (mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_ACTUATOR,
                         mujoco.mjtObj.mjOBJ_GEOM, mujoco.mjtObj.mjOBJ_KEY)
        base_joint = must(J, self.spec["base_joint"])
        if m.jnt_type[base_joint] != mujoco.mjtJoint.mjJNT_FREE:
            raise SystemExit(f"base_joint {self.spec['base_joint']} is not a free joint")
        self.base_qpos = int(m.jnt_qposadr[base_joint])
        self.base_dof = int(m.jnt_dofadr[base_joint])
        self.torso = must(B, self.spec["base_body"])
        if int(m.jnt_bodyid[base_joint]) != self.torso or np.any(m.jnt_pos[base_joint] != 0):
            print("warning: the free joint is not at the base body's origin", file=sys.stderr)
        self.key = must(K, self.spec["stand_keyframe"])
        motors = self.spec["motors"]
        order = json.loads(meta["motor_order"])
        if order != [mo["actuator"] for mo in motors]:
            raise SystemExit(f"ONNX motor_order {order} differs from the spec's [[motors]] {spec_path}")
        self.actuators = np.array([must(A, mo["actuator"]) for mo in motors])
        drives = [must(J, mo["drives"]) for mo in motors]
        self.motor_qpos = np.array([m.jnt_qposadr[j] for j in drives])
        self.motor_dof = np.array([m.jnt_dofadr[j] for j in drives])
        self.motor_range = np.array([mo["motor_range"] for mo in motors], dtype=float)
        self.foot_bodies = {must(B, f["body"]) for f in self.spec["feet"]}
        self.foot_geoms = {must(G, f["geom"]) for f in self.spec["feet"]}
        # Fall bodies (indices.rs): every body but the world and the feet; ground: geoms welded to the world.
        self.fall_bodies = set(range(1, m.nbody)) - self.foot_bodies
        self.ground_geom = np.array([m.body_weldid[m.geom_bodyid[g]] == 0 for g in range(m.ngeom)])
        key_qpos = m.key_qpos[self.key]
        self.key_motor_pos = key_qpos[self.motor_qpos].copy()

    def reset(self, base_vel6):
        m, d = self.model, self.data
        mujoco.mj_resetDataKeyframe(m, d, self.key)
        d.time = 0.0
        d.xfrc_applied[:] = 0.0
        d.qvel[self.base_dof:self.base_dof + 6] = base_vel6
        mujoco.mj_forward(m, d)

    def state(self):
        """What state.rs reads after a step (no forward call: contacts are those of the step's last evaluation)."""
        d = self.data
        b, v = self.base_qpos, self.base_dof
        q = d.qpos[b + 3:b + 7].copy()
        r = quat_to_mat(q)
        # MuJoCo's free joint: linear velocity in the world frame, angular velocity in the body's frame.
        lin = r.T @ d.qvel[v:v + 3]
        ang = d.qvel[v + 3:v + 6].copy()
        gravity = r.T @ np.array([0.0, 0.0, -1.0])
        roll, pitch, yaw = euler_rpy(r)
        return {
            "height": float(d.qpos[b + 2]),
            "lin": lin,
            "ang": ang,
            "gravity": gravity,
            "roll": roll,
            "pitch": pitch,
            "motor_pos": d.qpos[self.motor_qpos].copy(),
            "motor_vel": d.qvel[self.motor_dof].copy(),
            "torque": d.actuator_force[self.actuators].copy(),
        }

    def body_contact(self):
        m, d = self.model, self.data
        for i in range(d.ncon):
            g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
            if self.ground_geom[g1]:
                other = g2
            elif self.ground_geom[g2]:
                other = g1
            else:
                continue
            if other in self.foot_geoms:
                continue
            if int(m.geom_bodyid[other]) in self.fall_bodies:
                return True
        return False

    def check_velocity_convention(self):
        """After a forward call: the free joint's qvel, read as state.rs reads it, against mj_objectVelocity."""
        res = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, self.torso, res, 1)
        s = self.state()
        return float(max(np.abs(res[3:] - s["lin"]).max(), np.abs(res[:3] - s["ang"]).max()))


class Accumulator:
    def __init__(self):
        self.n, self.err, self.vel = 0, np.zeros(3), np.zeros(3)
        self.torque = self.roll = self.pitch = 0.0

    def add(self, cmd, s):
        measured = np.array([s["lin"][0], s["lin"][1], s["ang"][2]])
        self.n += 1
        self.err += np.abs(measured - cmd)
        self.vel += measured
        self.torque += float(np.abs(s["torque"]).sum())
        self.roll += s["roll"]
        self.pitch += s["pitch"]

    def means(self):
        if self.n == 0:
            nan = float("nan")
            return {"components": [nan] * 3, "velocity": [nan] * 3, "torque": nan, "roll": nan, "pitch": nan}
        return {"components": (self.err / self.n).tolist(), "velocity": (self.vel / self.n).tolist(),
                "torque": self.torque / self.n, "roll": self.roll / self.n, "pitch": self.pitch / self.n}


def stood_still(command, velocity):
    cc = sum(c * c for c in command)
    vc = sum(c * v for c, v in zip(command, velocity))
    return cc > 1e-12 and math.isfinite(vc) and vc < STAND_STILL_SHARE * cc


def find_policy_config(meta, spec_path: Path, explicit: str | None):
    """The policy's training config (termination thresholds, command ranges): --policy-json, else the metadata's
    policy_file relative to the working directory or the repository holding the spec."""
    candidates = [Path(explicit)] if explicit else []
    pf = meta.get("policy_file")
    if pf and not explicit:
        candidates += [Path(pf), spec_path.resolve().parent.parent.parent / pf]
    for c in candidates:
        if c.is_file():
            with open(c) as f:
                j = json.load(f)
            env = j.get("provenance", {}).get("config", {}).get("env", {})
            return str(c), env
    if explicit:
        raise SystemExit(f"--policy-json {explicit}: no such file")
    return None, {}


def run(args):
    _self_test_chacha()
    sess = ort.InferenceSession(args.onnx, providers=["CPUExecutionProvider"])
    meta = sess.get_modelmeta().custom_metadata_map
    outputs = [o.name for o in sess.get_outputs()]
    if "motor_targets" not in outputs:
        raise SystemExit(f"{args.onnx} has no motor_targets output: export it with `topa export --motor-targets`")
    obs_dim = sess.get_inputs()[0].shape[1]
    layout = {b["name"]: (b["offset"], b["size"]) for b in json.loads(meta["observation_layout"])}
    expected = ["base_linear_velocity", "base_angular_velocity", "projected_gravity", "motor_position_minus_nominal",
                "motor_velocity", "previous_action", "command_vx_vy_wz"]
    if sorted(layout) != sorted(expected):
        raise SystemExit(f"unknown observation layout {sorted(layout)} (a height scan is not supported here)")
    if sum(s for _, s in layout.values()) != obs_dim:
        raise SystemExit(f"the layout's blocks do not add up to the input's {obs_dim} values")
    nominal = np.array(json.loads(meta["nominal_motor_positions_rad"]))
    action_zero = np.array(json.loads(meta["action_zero_motor_positions_rad"]))
    action_scale = float(meta["action_scale_rad"])
    action_clip = float(meta["action_clip"])
    period = float(meta["control_period_s"])

    spec_path = Path(args.spec)
    robot = Robot(spec_path, meta, args.timestep)
    m = robot.model
    dt_phys = float(m.opt.timestep)
    dec = period / dt_phys
    if abs(dec - round(dec)) > 1e-6 or round(dec) < 1:
        raise SystemExit(f"the timestep {dt_phys} s does not divide the control period {period} s")
    decimation = int(round(dec))
    if np.abs(robot.key_motor_pos - nominal).max() > 1e-9:
        print(f"warning: the ONNX nominal {nominal} differs from the keyframe's motors {robot.key_motor_pos}",
              file=sys.stderr)

    policy_json, env_cfg = find_policy_config(meta, spec_path, args.policy_json)
    term = {**DEFAULT_TERMINATION, **env_cfg.get("termination", {})}
    cmd_cfg = {**DEFAULT_COMMANDS, **env_cfg.get("commands", {})}

    settle = int(round(SETTLE_S / period))
    window = int(round(args.seconds / period))
    transient = min(2.0, args.seconds / 2.0)
    k = len(COMMANDS)
    n_env = args.starts * k

    def write_obs(s, last_action, command):
        obs = np.zeros(obs_dim, dtype=np.float64)
        put = lambda name, v: obs.__setitem__(slice(layout[name][0], layout[name][0] + layout[name][1]), v)  # noqa
        put("base_linear_velocity", s["lin"])
        put("base_angular_velocity", s["ang"])
        g = s["gravity"]
        put("projected_gravity", g / np.linalg.norm(g) if np.linalg.norm(g) > 1e-9 else g)
        put("motor_position_minus_nominal", s["motor_pos"] - nominal)
        put("motor_velocity", s["motor_vel"])
        put("previous_action", last_action)
        put("command_vx_vy_wz", command)
        return obs.astype(np.float32)[None, :]  # each value rounded f64 -> f32 as observe.rs does

    results = [None] * n_env
    max_target_dev = 0.0
    convention_err = 0.0
    warnings_seen = {}
    for env in range(n_env):
        command = np.array(COMMANDS[env % k][1])
        rng = RustEnvRng(args.seed, env)
        base_vel = [rng.range_f64(-0.1, 0.1) for _ in range(6)]  # mod.rs reset: qvel[dof + i], i = 0..6
        # sample_command() at the reset: the first observation carries it (see the module's docstring).
        kind = rng.random_f64()
        if kind < cmd_cfg["standing_share"]:
            reset_cmd = [0.0, 0.0, 0.0]
        else:
            draw = lambda r: rng.range_f64(r[0], r[1]) if r[1] > r[0] else r[0]  # noqa: E731
            if kind < cmd_cfg["standing_share"] + cmd_cfg["turn_share"]:
                reset_cmd = [0.0, 0.0, draw(cmd_cfg["ang_vel_z"])]
            else:
                reset_cmd = [draw(cmd_cfg["lin_vel_x"]), draw(cmd_cfg["lin_vel_y"]), draw(cmd_cfg["ang_vel_z"])]
                if math.hypot(reset_cmd[0], reset_cmd[1]) < cmd_cfg["min_lin_norm"]:
                    reset_cmd[0] = reset_cmd[1] = 0.0
        robot.reset(base_vel)
        convention_err = max(convention_err, robot.check_velocity_convention())
        last_action = np.zeros(len(nominal))
        s = robot.state()
        obs = write_obs(s, last_action, np.array(reset_cmd))
        current_cmd = np.zeros(3)  # the runner's override right after the reset
        whole, ours = Accumulator(), Accumulator()
        fell_at = None
        diverged = False
        for step in range(settle + window):
            if step == settle:
                current_cmd = command  # setup(): the override changes; `obs` is not rewritten
            action, targets = sess.run(["action", "motor_targets"], {"obs": obs})
            a = action[0].astype(np.float64)
            a = np.where(np.isfinite(a), np.clip(a, -action_clip, action_clip), 0.0)
            ref = np.clip(action_zero + action_scale * a, robot.motor_range[:, 0], robot.motor_range[:, 1])
            max_target_dev = max(max_target_dev, float(np.abs(targets[0] - ref).max()))
            robot.data.ctrl[robot.actuators] = targets[0]
            for _ in range(decimation):
                mujoco.mj_step(m, robot.data)
            for w in range(len(robot.data.warning)):
                if robot.data.warning[w].number:
                    warnings_seen[mujoco.mjtWarning(w).name] = int(robot.data.warning[w].number)
            if not np.all(np.isfinite(robot.data.qacc)) or not np.all(np.isfinite(robot.data.qpos)):
                diverged = True
            last_action = a
            s = robot.state()
            t_window = (step + 1 - settle) * period if step >= settle else 0.0
            fallen_now = (s["height"] < term["min_base_height"] or abs(s["roll"]) > term["max_tilt"]
                          or abs(s["pitch"]) > term["max_tilt"] or (term["body_contact"] and robot.body_contact()))
            if fell_at is None and (fallen_now or diverged):
                fell_at = t_window
            if step >= settle:
                whole.add(command, s)
                if t_window > transient and fell_at is None:
                    ours.add(command, s)
            obs = write_obs(s, last_action, current_cmd)
            if diverged:
                break
        results[env] = {"ours": ours.means(), "whole": whole.means(), "fell_at": fell_at, "diverged": diverged}

    rows = []
    for c, (key, cmd) in enumerate(COMMANDS):
        rs = [results[s * k + c] for s in range(args.starts)]
        mean = lambda f: sum(f(r) for r in rs) / len(rs)  # noqa: E731
        comps = [mean(lambda r: r["ours"]["components"][i]) for i in range(3)]
        wh = [mean(lambda r: r["whole"]["components"][i]) for i in range(3)]
        falls = [r["fell_at"] for r in rs if r["fell_at"] is not None]
        rows.append({
            "key": key,
            "command": list(cmd),
            "mae": sum(comps) / 3.0,
            "mae_components": comps,
            "mae_whole": wh,
            "mae_paper": sum(wh),
            "mean_torque": mean(lambda r: r["whole"]["torque"]),
            "mean_roll": mean(lambda r: r["whole"]["roll"]),
            "mean_pitch": mean(lambda r: r["whole"]["pitch"]),
            "fell": bool(falls),
            "fell_at": min(falls) if falls else None,
            "starts": len(rs),
            "falls": len(falls),
            "stood_still": sum(stood_still(cmd, r["ours"]["velocity"]) for r in rs),
            "per_start": [{"fell_at": r["fell_at"], "mae_whole": r["whole"]["components"],
                           "mae_components": r["ours"]["components"], "diverged": r["diverged"]} for r in rs],
        })
    report = {
        "evaluator": "scripts/mujoco_release/eval_tracking.py",
        "mujoco": mujoco.__version__,
        "onnxruntime": ort.__version__,
        "onnx": args.onnx,
        "policy_file": meta.get("policy_file"),
        "policy_config_read_from": policy_json,
        "mjcf": str(robot.mjcf),
        "timestep": dt_phys,
        "mjcf_timestep": robot.mjcf_timestep,
        "integrator": mujoco.mjtIntegrator(int(m.opt.integrator)).name,
        "decimation": decimation,
        "settle_s": SETTLE_S,
        "seconds": args.seconds,
        "transient_s": transient,
        "starts": args.starts,
        "seed": args.seed,
        "termination": term,
        "max_motor_target_vs_f64_recompute": max_target_dev,
        "max_velocity_convention_error": convention_err,
        "mujoco_warnings": warnings_seen,
        "rows": rows,
    }
    return report


def print_table(report):
    print(f"MuJoCo {report['mujoco']}, {report['integrator']} at {report['timestep']} s x {report['decimation']}, "
          f"{report['starts']} start(s) x {report['seconds']} s, policy {report['policy_file']}")
    print(f"{'command':<14} {'falls':>5} {'MAE vx':>7} {'MAE vy':>7} {'MAE wz':>7} {'sum':>6} | "
          f"{'steady vx':>9} {'vy':>6} {'wz':>6} {'stood':>5}")
    for r in report["rows"]:
        w, o = r["mae_whole"], r["mae_components"]
        print(f"{r['key']:<14} {r['falls']:>5} {w[0]:7.3f} {w[1]:7.3f} {w[2]:7.3f} {r['mae_paper']:6.3f} | "
              f"{o[0]:9.3f} {o[1]:6.3f} {o[2]:6.3f} {r['stood_still']:>5}")
    if report["mujoco_warnings"]:
        print("MuJoCo warnings:", report["mujoco_warnings"])


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--onnx", required=True, help="policy exported with `topa export --motor-targets`")
    p.add_argument("--spec", required=True, help="robot spec, e.g. assets/robots/topa_closed.toml")
    p.add_argument("--seconds", type=float, default=10.0, help="window per command, s (default 10)")
    p.add_argument("--starts", type=int, default=10, help="initial states per command (default 10)")
    p.add_argument("--timestep", type=float, default=0.0025,
                   help="physics timestep, s (default 0.0025, the Rust evaluator's; must divide control_period_s)")
    p.add_argument("--seed", type=int, default=SEED, help="the Rust evaluator's --seed: picks the starts (default 1)")
    p.add_argument("--policy-json", default=None,
                   help="the policy's sidecar, for its termination thresholds and command ranges (default: the "
                        "ONNX metadata's policy_file, if found; else topa-env's defaults)")
    p.add_argument("--json", default=None, help="write the report here ('-' for stdout)")
    args = p.parse_args()
    if args.starts < 1:
        raise SystemExit("--starts must be >= 1")
    report = run(args)
    if args.json == "-":
        json.dump(report, sys.stdout, indent=2)
        print()
        return
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(report, f, indent=2)
    print_table(report)


if __name__ == "__main__":
    main()
