//! `topa config reference` and `topa config show`: the Markdown configuration reference (docs/configuration.md),
//! made from the config types' JSON Schema (types, doc comments) and their `Default`s, and a config file fully
//! resolved as TOML.

use std::collections::BTreeSet;
use std::path::Path;

use schemars::JsonSchema;
use serde::Serialize;
use serde_json::Value as Json;
use topa_env::EnvConfig;
use trainer::config::{AdversaryConfig, LossConfig, NetworkConfig, PpoConfig, RunConfig, TrainConfig};

use crate::error::{Error, Result};

/// A training config with its `[env]` table typed, every key present: what `topa config show` prints. The
/// learner's tables come first, then the task's, each in its fields' order.
#[derive(Serialize)]
struct Resolved<'a> {
    run: &'a RunConfig,
    ppo: &'a PpoConfig,
    network: &'a NetworkConfig,
    losses: &'a LossConfig,
    adversary: &'a AdversaryConfig,
    env: &'a EnvConfig,
}

impl<'a> Resolved<'a> {
    fn new(cfg: &'a TrainConfig, env: &'a EnvConfig) -> Self {
        Resolved {
            run: &cfg.run,
            ppo: &cfg.ppo,
            network: &cfg.network,
            losses: &cfg.losses,
            adversary: &cfg.adversary,
            env,
        }
    }
}

/// `cfg` with `env` as TOML text, every key with its value (the file's or the default).
pub fn resolved_toml(cfg: &TrainConfig, env: &EnvConfig) -> Result<String> {
    toml::to_string(&Resolved::new(cfg, env)).map_err(Error::Toml)
}

/// The same as a table (for lookups by key).
pub fn resolved_table(cfg: &TrainConfig, env: &EnvConfig) -> Result<toml::Table> {
    toml::Table::try_from(Resolved::new(cfg, env)).map_err(Error::Toml)
}

/// `topa config show FILE`: the file with its `base` chain merged and every key it leaves out at its default.
pub fn show(path: &Path) -> Result<String> {
    let (cfg, env) = topa_train::load_config(path)?;
    Ok(format!(
        "# {} resolved by `topa config show`: its base chain merged, every key with its value or default.\n\n{}",
        path.display(),
        resolved_toml(&cfg, &env)?
    ))
}

/// One key of the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub key: String,
    pub ty: String,
    /// The `Default` value, as TOML.
    pub default: String,
    /// The value the paper preset resolves to, as TOML; empty where it neither sets the key nor differs.
    pub paper: String,
    pub description: String,
}

/// One TOML table of the reference: its dotted name (`env.commands`), what it holds, its keys.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    pub table: String,
    pub about: String,
    pub rows: Vec<Row>,
}

impl Section {
    /// The table's keys with their table: `env.commands.lin_vel_x`.
    pub fn dotted_keys(&self) -> impl Iterator<Item = String> + '_ {
        self.rows.iter().map(|r| format!("{}.{}", self.table, r.key))
    }

    /// The keys every resolved config has (the optional ones, default "none", left out).
    pub fn resolved_keys(&self) -> impl Iterator<Item = String> + '_ {
        self.rows.iter().filter(|r| r.default != OPTIONAL).map(|r| format!("{}.{}", self.table, r.key))
    }
}

/// The default column of a key that has none (the model's or the robot's own value applies).
const OPTIONAL: &str = "none";

fn schema_of<T: JsonSchema>() -> Json {
    schemars::schema_for!(T).to_value()
}

/// Every table and key, in the order `topa config show` prints them, with the paper preset at `paper`.
pub fn sections(paper: &Path) -> Result<Vec<Section>> {
    let (cfg, env) = (TrainConfig::default(), EnvConfig::default());
    let defaults = resolved_table(&cfg, &env)?;
    let (paper_cfg, paper_env) = topa_train::load_config(paper)?;
    let paper_values = resolved_table(&paper_cfg, &paper_env)?;
    // What the preset itself writes (its base chain merged), to tell "set" from "default".
    let written = trainer::config::load_table(paper, 0)?;
    let schemas = Schemas { learner: schema_of::<TrainConfig>(), env: schema_of::<EnvConfig>() };

    let mut out = Vec::new();
    // The TOML text gives the fields' declared order (the tables and schemas sort their keys).
    for (table, keys) in table_order(&resolved_toml(&cfg, &env)?) {
        let path: Vec<&str> = table.split('.').collect();
        let about = schemas.property(&path).and_then(|(_, p)| description(p)).unwrap_or_default();
        let mut rows = Vec::new();
        // Optional keys (no default: the model's or the robot's own value) are in the schema, not the table.
        let optional: Vec<(String, Json)> = schemas
            .property(&path)
            .map(|(root, node)| resolve(root, node))
            .and_then(|n| n.get("properties").and_then(|p| p.as_object()))
            .map(|props| {
                props
                    .iter()
                    .filter(|(k, _)| {
                        let full: Vec<&str> = path.iter().copied().chain([k.as_str()]).collect();
                        lookup(&defaults, &full).is_none() // neither a listed key nor a sub-table
                    })
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .collect()
            })
            .unwrap_or_default();
        for key in keys {
            let full: Vec<&str> = path.iter().copied().chain([key.as_str()]).collect();
            let (root, prop) =
                schemas.property(&full).ok_or_else(|| Error::Schema(format!("{table}.{key} is not in the schema")))?;
            let default =
                lookup(&defaults, &full).ok_or_else(|| Error::Schema(format!("{table}.{key} has no default")))?;
            let paper_value =
                lookup(&paper_values, &full).ok_or_else(|| Error::Schema(format!("{table}.{key}: paper")))?;
            let set = lookup(&written, &full).is_some() || (full == ["env", "robot"] && written_model(&written));
            rows.push(Row {
                ty: type_name(root, prop),
                default: format!("`{default}`"),
                paper: if set || paper_value != default { format!("`{paper_value}`") } else { String::new() },
                description: [description(prop), variants(root, prop)]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>()
                    .join(" "),
                key,
            });
        }
        for (key, prop) in optional {
            let full: Vec<&str> = path.iter().copied().chain([key.as_str()]).collect();
            let root = if path.first() == Some(&"env") { &schemas.env } else { &schemas.learner };
            let paper_value = lookup(&paper_values, &full).map(|v| format!("`{v}`")).unwrap_or_default();
            rows.push(Row {
                ty: type_name(root, &prop),
                default: OPTIONAL.into(),
                paper: paper_value,
                description: description(&prop).unwrap_or_default(),
                key,
            });
        }
        out.push(Section { table, about, rows });
    }
    Ok(out)
}

/// `topa config reference`: the Markdown reference of every table and key.
pub fn reference(paper: &Path) -> Result<String> {
    Ok(render(&sections(paper)?, paper))
}

/// Markdown for `sections` (the intro names the preset of the paper column).
pub fn render(sections: &[Section], paper: &Path) -> String {
    let mut md = String::from("# Configuration reference\n\n");
    md.push_str(&format!(
        "Generated by `topa config reference` from the config types (their doc comments and defaults); do not edit \
         by hand: `topa config reference > docs/configuration.md`. A training config is a TOML file with the tables \
         below: a key left out takes its default, an unknown key is an error. A file may start from another: \
         `base = \"cpu.toml\"` (relative to the file) loads that file first (and its own base, up to 8 levels), \
         then applies this file's keys on top, table by table, so an experiment holds only what it changes. \
         `topa config show FILE` prints a file fully resolved. The paper column is the value `{}` (the paper's \
         table) resolves to, where it sets the key or differs from the default.\n",
        paper.display()
    ));
    for s in sections {
        md.push_str(&format!("\n## [{}]\n\n", s.table));
        if !s.about.is_empty() {
            md.push_str(&format!("{}\n\n", cell(&s.about)));
        }
        md.push_str("| key | type | default | paper | description |\n| --- | --- | --- | --- | --- |\n");
        for r in &s.rows {
            md.push_str(&format!(
                "| `{}` | {} | {} | {} | {} |\n",
                r.key,
                cell(&r.ty),
                cell(&r.default),
                cell(&r.paper),
                cell(&r.description)
            ));
        }
    }
    md
}

/// Text for one Markdown table cell: one line, pipes escaped.
fn cell(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ").replace('|', "\\|")
}

/// The tables of a TOML text written by `toml::to_string`, each with its keys, in the text's order. Only what
/// that writer emits is read: `[a.b]` headers and `key = value` lines (arrays stay on one line).
fn table_order(text: &str) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = vec![(String::new(), Vec::new())];
    for line in text.lines() {
        if let Some(header) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            out.push((header.to_string(), Vec::new()));
        } else if let Some((key, _)) = line.split_once(" = ") {
            out.last_mut().expect("starts with the root").1.push(key.to_string());
        }
    }
    out.retain(|(_, keys)| !keys.is_empty());
    out
}

/// The value at a dotted path of a table.
fn lookup<'t>(t: &'t toml::Table, path: &[&str]) -> Option<&'t toml::Value> {
    let (last, tables) = path.split_last()?;
    let mut t = t;
    for k in tables {
        t = t.get(*k)?.as_table()?;
    }
    t.get(*last)
}

/// Earlier presets name TopA's model (`[env] model = "closed"`), which sets `env.robot`.
fn written_model(written: &toml::Table) -> bool {
    lookup(written, &["env", "model"]).is_some()
}

fn description(prop: &Json) -> Option<String> {
    prop.get("description").and_then(Json::as_str).map(|d| d.split_whitespace().collect::<Vec<_>>().join(" "))
}

/// The learner's schema (its `env` skipped) and the task's.
struct Schemas {
    learner: Json,
    env: Json,
}

impl Schemas {
    /// The schema of the field at `path` (as the parent lists it: with the field's own description), and the
    /// schema whose definitions its `$ref`s name.
    fn property(&self, path: &[&str]) -> Option<(&Json, &Json)> {
        let (root, rest) = match path {
            ["env", rest @ ..] => (&self.env, rest),
            _ => (&self.learner, path),
        };
        let mut node = root;
        for key in rest {
            node = find_property(root, node, key)?;
        }
        Some((root, node))
    }
}

/// A `$ref` followed to its definition.
fn resolve<'s>(root: &'s Json, node: &'s Json) -> &'s Json {
    match node.get("$ref").and_then(Json::as_str).and_then(|r| r.strip_prefix("#/$defs/")) {
        Some(name) => root["$defs"].get(name).unwrap_or(node),
        None => node,
    }
}

/// A property of an object schema, also inside `allOf`/`anyOf`/`oneOf` (where flattened fields may land).
fn find_property<'s>(root: &'s Json, node: &'s Json, key: &str) -> Option<&'s Json> {
    let node = resolve(root, node);
    if let Some(p) = node.get("properties").and_then(|p| p.get(key)) {
        return Some(p);
    }
    ["allOf", "anyOf", "oneOf"]
        .iter()
        .filter_map(|c| node.get(*c).and_then(Json::as_array))
        .flatten()
        .find_map(|sub| find_property(root, sub, key))
}

/// An enum's values with their doc comments, where its variants have them: "Values: `a`: …; `b`: …".
fn variants(root: &Json, prop: &Json) -> Option<String> {
    let alts = resolve(root, prop).get("oneOf")?.as_array()?;
    let described: Vec<String> =
        alts.iter().filter_map(|a| Some(format!("`{}`: {}", a.get("const")?.as_str()?, description(a)?))).collect();
    (!described.is_empty()).then(|| format!("Values: {}", described.join(" ")))
}

/// A short type: `number`, `integer`, `bool`, `string`, `[number; 2]`, `[integer]`, or an enum's values.
fn type_name(root: &Json, prop: &Json) -> String {
    let node = resolve(root, prop);
    let mut values: Vec<String> = Vec::new();
    if let Some(e) = node.get("enum").and_then(Json::as_array) {
        values.extend(e.iter().map(|v| format!("`{}`", v.as_str().map_or(v.to_string(), str::to_string))));
    }
    for alt in node.get("oneOf").and_then(Json::as_array).into_iter().flatten() {
        if let Some(c) = alt.get("const") {
            values.push(format!("`{}`", c.as_str().map_or(c.to_string(), str::to_string)));
        }
        if let Some(e) = alt.get("enum").and_then(Json::as_array) {
            values.extend(e.iter().map(|v| format!("`{}`", v.as_str().map_or(v.to_string(), str::to_string))));
        }
    }
    if !values.is_empty() {
        return values.join(" / ");
    }
    match node.get("type").and_then(Json::as_str) {
        Some("boolean") => "bool".into(),
        Some("array") => {
            let item = node.get("items").map_or("value".to_string(), |i| type_name(root, i));
            let (lo, hi) = (node.get("minItems"), node.get("maxItems"));
            match (lo, hi) {
                (Some(lo), Some(hi)) if lo == hi => format!("[{item}; {lo}]"),
                _ => format!("[{item}]"),
            }
        }
        Some("object") => "table".into(),
        Some(t) => t.to_string(),
        None => "value".into(),
    }
}

/// Every leaf key of a table, dotted (`env.commands.lin_vel_x`): arrays are leaves, tables are not.
pub fn leaf_keys(t: &toml::Table) -> BTreeSet<String> {
    fn walk(t: &toml::Table, prefix: &str, out: &mut BTreeSet<String>) {
        for (k, v) in t {
            let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
            match v {
                toml::Value::Table(sub) => walk(sub, &key, out),
                _ => {
                    out.insert(key);
                }
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(t, "", &mut out);
    out
}
