//! `topa export --onnx OUT.onnx --policy P.json`: the actor as an ONNX model for the robot's computer, with the
//! observation normaliser in the graph, written through the ONNX protobuf types of `tract-onnx` (prost).
//!
//! The model (opset 17, IR 8), for a robot with n motors (TopA: n = 10, 42 observations):
//! * input `obs`: float32 `[batch, 12 + 3n]`, the robot's observation in motor space, laid out as in the
//!   `observation_layout` metadata entry (the env's `[v, ω, g, q − q_nominal, q̇, a_prev, c]`);
//! * output `action`: float32 `[batch, n]`, the policy's mean action in motor space (motor target offsets in units
//!   of `action_scale` rad);
//! * with `--motor-targets`, output `motor_targets`: float32 `[batch, n]`, what the motors receive:
//!   `clamp(action_zero + action_scale · clip(action, ±action_clip), motor range)`, in rad (`action_zero`: the
//!   stand pose plus any feed-forward torque over kp).
//!
//! Everything robot-specific comes from the robot's spec and MJCF (through `PolicyRunner`): the
//! layout, the motor order, the stand pose and the ranges. A policy trained on a simplified model (TopA's serial
//! chain, whose spec `approximates` the closed robot) acts in joint space; its graph maps the observation's motor
//! blocks to joint space and the action back through the linkage's constant J (the paper's M, computed from the
//! constraints), as `topa eval` does, so every exported model takes and returns motor space. Where that linkage is
//! nonlinear no constant map exists and the export is refused (the runner says so). The metadata names the robot,
//! the layout, the control period and the policy file's checksum, so a model can be matched to its policy
//! (`--check`).

use std::path::Path;

use prost::Message;
use topa_env::observation::{Block, ObsLayout};
use tract_onnx::pb;
use trainer::policy_file::Policy;

use topa_env::policy_runner::PolicyRunner;

use crate::error::{bad_file, Error, Result};

pub const OPSET: i64 = 17;
pub const INPUT: &str = "obs";
pub const OUTPUT: &str = "action";
pub const TARGETS: &str = "motor_targets";
const FLOAT: i32 = 1;
const DOUBLE: i32 = 11;

/// The observation blocks (name, offset, size), as the metadata lists them.
pub fn observation_layout(layout: ObsLayout) -> Vec<(&'static str, usize, usize)> {
    layout.blocks().into_iter().map(|(b, offset, size)| (b.name(), offset, size)).collect()
}

fn tensor(name: &str, dims: &[usize], data: Vec<f32>) -> pb::TensorProto {
    pb::TensorProto {
        name: name.into(),
        dims: dims.iter().map(|&d| d as i64).collect(),
        data_type: FLOAT,
        float_data: data,
        ..Default::default()
    }
}

fn tensor_f64(name: &str, data: Vec<f64>) -> pb::TensorProto {
    pb::TensorProto {
        name: name.into(),
        dims: vec![data.len() as i64],
        data_type: DOUBLE,
        double_data: data,
        ..Default::default()
    }
}

fn value_info(name: &str, cols: usize) -> pb::ValueInfoProto {
    use pb::tensor_shape_proto::{dimension::Value as Dim, Dimension};
    let dim = |v: Dim| Dimension { value: Some(v), ..Default::default() };
    pb::ValueInfoProto {
        name: name.into(),
        r#type: Some(pb::TypeProto {
            value: Some(pb::type_proto::Value::TensorType(pb::type_proto::Tensor {
                elem_type: FLOAT,
                shape: Some(pb::TensorShapeProto {
                    dim: vec![dim(Dim::DimParam("batch".into())), dim(Dim::DimValue(cols as i64))],
                }),
            })),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn node(op: &str, inputs: &[&str], output: &str, attributes: Vec<pb::AttributeProto>) -> pb::NodeProto {
    pb::NodeProto {
        op_type: op.into(),
        name: output.into(),
        input: inputs.iter().map(|s| s.to_string()).collect(),
        output: vec![output.into()],
        attribute: attributes,
        ..Default::default()
    }
}

fn float_attr(name: &str, v: f32) -> pb::AttributeProto {
    pb::AttributeProto { name: name.into(), r#type: 1, f: v, ..Default::default() }
}

fn int_attr(name: &str, v: i64) -> pb::AttributeProto {
    pb::AttributeProto { name: name.into(), r#type: 2, i: v, ..Default::default() }
}

/// The matrix `T` with `row · T` = the linear map `f` applied to a row (`f` given on basis vectors).
fn row_map(n: usize, f: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f32> {
    let mut t = vec![0.0f32; n * n];
    for i in 0..n {
        let mut e = vec![0.0; n];
        e[i] = 1.0;
        for (j, v) in f(&e).iter().enumerate() {
            t[i * n + j] = *v as f32;
        }
    }
    t
}

/// Builds the ONNX model of the runner's policy (loaded from `source`) for the robot it runs on.
pub fn build(runner: &PolicyRunner, source: &str, motor_targets: bool) -> Result<pb::ModelProto> {
    let policy = &runner.policy;
    let m = &policy.meta;
    let robot = runner.robot();
    let layout = runner.layout();
    let (n, row) = (layout.n_motors, layout.dim());
    if m.obs_dim != row || m.action_dim != n {
        bad_file!("{source}: a {}→{} policy cannot drive {} ({row} → {n})", m.obs_dim, m.action_dim, robot.name);
    }
    // The graph reads what the actor reads: the row up to the privileged values a robot does not have.
    let view = policy.view();
    let obs_dim = view.inputs;
    let (mut nodes, mut inits) = (Vec::new(), Vec::new());
    let mut x = INPUT.to_string();
    let map = runner.joint_map();
    if let Some((j, _)) = map {
        // Motor-space observation → the joint space the policy was trained in: J on q, q̇ and a_prev, in the
        // current frame and in every earlier one.
        let motor_blocks: Vec<usize> = [Block::MotorPos, Block::MotorVel, Block::LastAction]
            .iter()
            .map(|&b| layout.offset(b))
            .chain((0..layout.history).flat_map(|k| {
                let frame = layout.offset(Block::History) + k * layout.frame();
                layout
                    .frame_blocks()
                    .into_iter()
                    .filter(|(b, _, _)| matches!(b, Block::MotorPos | Block::MotorVel | Block::LastAction))
                    .map(move |(_, at, _)| frame + at)
            }))
            .collect();
        let t = row_map(obs_dim, |e| {
            let mut o = e.to_vec();
            for &at in &motor_blocks {
                for i in 0..n {
                    o[at + i] = (0..n).map(|k| j[(i, k)] * e[at + k]).sum();
                }
            }
            o
        });
        inits.push(tensor("motor_to_joint_obs", &[obs_dim, obs_dim], t));
        nodes.push(node("MatMul", &[INPUT, "motor_to_joint_obs"], "obs_joint", vec![]));
        x = "obs_joint".into();
    }
    // The normaliser in double precision, as the trainer computes it, rounded to float once at the end.
    let (mean, scale) = policy.normalizer_affine();
    inits.push(tensor_f64("obs_mean", mean[..obs_dim].to_vec()));
    inits.push(tensor_f64("obs_scale", scale[..obs_dim].to_vec()));
    nodes.push(node("Cast", &[&x], "obs_f64", vec![int_attr("to", DOUBLE as i64)]));
    nodes.push(node("Sub", &["obs_f64", "obs_mean"], "obs_centred", vec![]));
    nodes.push(node("Mul", &["obs_centred", "obs_scale"], "obs_scaled", vec![]));
    nodes.push(node("Cast", &["obs_scaled"], "obs_normalised", vec![int_attr("to", FLOAT as i64)]));
    x = "obs_normalised".into();
    if let Some(e) = policy.estimator() {
        // The concurrent estimator's output (normalised, as the actor read it) follows the observation.
        mlp_nodes("estimator", &e.layers, &x, "estimate_normalised", &mut nodes, &mut inits)?;
        nodes.push(node("Concat", &[&x, "estimate_normalised"], "actor_input", vec![int_attr("axis", 1)]));
        x = "actor_input".into();
    }
    let out = if map.is_none() { OUTPUT } else { "action_joint" };
    mlp_nodes("actor", &policy.actor().layers, &x, out, &mut nodes, &mut inits)?;
    if let Some((_, inv)) = map {
        // Joint-space action → motor space: J⁻¹.
        let t = row_map(n, |e| (0..n).map(|i| (0..n).map(|k| inv[(i, k)] * e[k]).sum()).collect());
        inits.push(tensor("joint_to_motor_action", &[n, n], t));
        nodes.push(node("MatMul", &[out, "joint_to_motor_action"], OUTPUT, vec![]));
    }
    let mut outputs = vec![value_info(OUTPUT, n)];
    let nominal = runner.nominal_motors();
    if motor_targets {
        let clip = m.action_clip as f32;
        inits.push(tensor("action_min", &[], vec![-clip]));
        inits.push(tensor("action_max", &[], vec![clip]));
        inits.push(tensor("action_scale", &[], vec![m.action_scale as f32]));
        let zero = runner.action_zero();
        inits.push(tensor("action_zero_motor_positions", &[n], zero.iter().map(|&v| v as f32).collect()));
        inits.push(tensor("motor_min", &[n], robot.motors.iter().map(|mo| mo.motor_range[0] as f32).collect()));
        inits.push(tensor("motor_max", &[n], robot.motors.iter().map(|mo| mo.motor_range[1] as f32).collect()));
        nodes.push(node("Clip", &[OUTPUT, "action_min", "action_max"], "action_clipped", vec![]));
        nodes.push(node("Mul", &["action_clipped", "action_scale"], "target_offset", vec![]));
        nodes.push(node("Add", &["target_offset", "action_zero_motor_positions"], "target_raw", vec![]));
        nodes.push(node("Max", &["target_raw", "motor_min"], "target_low", vec![]));
        nodes.push(node("Min", &["target_low", "motor_max"], TARGETS, vec![]));
        outputs.push(value_info(TARGETS, n));
    }
    let layout: Vec<serde_json::Value> = observation_layout(layout)
        .iter()
        .filter(|(_, o, _)| *o < obs_dim)
        .map(|(n, o, s)| serde_json::json!({"name": n, "offset": o, "size": s}))
        .collect();
    let meta = [
        ("robot", robot.name.clone()),
        ("robot_spec", robot.path.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned())),
        ("trained_on_model", runner.trained_on().to_string()),
        ("observation_layout", serde_json::Value::Array(layout).to_string()),
        ("motor_order", serde_json::to_string(&robot.motors.iter().map(|mo| &mo.actuator).collect::<Vec<_>>())?),
        ("nominal_motor_positions_rad", serde_json::to_string(nominal)?),
        ("action_zero_motor_positions_rad", serde_json::to_string(runner.action_zero())?),
        ("action_scale_rad", m.action_scale.to_string()),
        ("action_clip", m.action_clip.to_string()),
        ("control_period_s", m.policy_dt.to_string()),
        ("policy_file", source.to_string()),
        ("policy_weights_crc32", m.weights_crc32.to_string()),
        ("opset", OPSET.to_string()),
    ];
    Ok(pb::ModelProto {
        ir_version: 8,
        opset_import: vec![pb::OperatorSetIdProto { domain: String::new(), version: OPSET }],
        producer_name: "topa".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        doc_string: format!(
            "{} locomotion policy: obs[batch, {obs_dim}] → action[batch, {n}] (see metadata)",
            robot.name
        ),
        graph: Some(pb::GraphProto {
            name: "topa_policy".into(),
            node: nodes,
            initializer: inits,
            input: vec![value_info(INPUT, obs_dim)],
            output: outputs,
            ..Default::default()
        }),
        metadata_props: meta.into_iter().map(|(k, v)| pb::StringStringEntryProto { key: k.into(), value: v }).collect(),
        ..Default::default()
    })
}

/// The nodes of an MLP (`net`: "actor", "estimator") from `input` to `output`: Gemm and ELU, the last layer linear.
fn mlp_nodes(
    net: &str,
    layers: &[trainer::nn::Linear],
    input: &str,
    output: &str,
    nodes: &mut Vec<pb::NodeProto>,
    inits: &mut Vec<pb::TensorProto>,
) -> Result<()> {
    let mut x = input.to_string();
    for (i, l) in layers.iter().enumerate() {
        let (w, b) = (format!("{net}.{i}.weight"), format!("{net}.{i}.bias"));
        inits.push(tensor(&w, &[l.out_dim(), l.in_dim()], l.weight.as_tensor().flatten_all()?.to_vec1()?));
        inits.push(tensor(&b, &[l.out_dim()], l.bias.as_tensor().to_vec1()?));
        let last = i + 1 == layers.len();
        let z = if last { output.to_string() } else { format!("{net}.{i}.linear") };
        nodes.push(node("Gemm", &[&x, &w, &b], &z, vec![int_attr("transB", 1)]));
        if !last {
            let y = format!("{net}.{i}.elu");
            nodes.push(node("Elu", &[&z], &y, vec![float_attr("alpha", 1.0)]));
            x = y;
        }
    }
    Ok(())
}

/// Writes the ONNX model of the policy at `policy_path` to `out` (atomically); returns the robot's observation
/// and motor counts, the graph's input and output widths.
pub fn export(policy_path: &Path, out: &Path, motor_targets: bool) -> Result<(usize, usize)> {
    let runner = PolicyRunner::load(policy_path, "export")?;
    let model = build(&runner, &policy_path.display().to_string(), motor_targets)?;
    trainer::tensorfile::write_atomic(out, &model.encode_to_vec())?;
    Ok((runner.policy.view().inputs, runner.layout().n_motors))
}

/// Reads an ONNX file written by `export`, refusing anything else with one clear error.
pub fn read(path: &Path) -> Result<pb::ModelProto> {
    let bytes = std::fs::read(path).map_err(Error::io("cannot read", path))?;
    let model = pb::ModelProto::decode(bytes.as_slice()).map_err(|e| {
        Error::file(format!("{} is not an ONNX model: export it again with `topa export`", path.display()), e)
    })?;
    let graph = model.graph.as_ref().ok_or_else(|| Error::bad_file(format!("{} holds no graph", path.display())))?;
    if graph.input.first().map(|i| i.name.as_str()) != Some(INPUT)
        || graph.output.first().map(|o| o.name.as_str()) != Some(OUTPUT)
    {
        bad_file!("{} is not a TopA policy model (no '{INPUT}' input / '{OUTPUT}' output)", path.display());
    }
    Ok(model)
}

/// Checks that the ONNX file belongs to the policy file: same weights checksum and architecture.
pub fn check(onnx: &Path, policy_path: &Path) -> Result<()> {
    let model = read(onnx)?;
    let policy = Policy::load(policy_path)?;
    let crc = model.metadata_props.iter().find(|p| p.key == "policy_weights_crc32").map(|p| p.value.clone());
    if crc.as_deref() != Some(policy.meta.weights_crc32.to_string().as_str()) {
        return Err(Error::NotExportedFrom {
            onnx: onnx.to_path_buf(),
            policy: policy_path.to_path_buf(),
            found: crc.unwrap_or_else(|| "missing".into()),
            expected: policy.meta.weights_crc32,
        });
    }
    Ok(())
}
