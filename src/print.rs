//! What the command line prints as JSON (`--json`): pretty, on standard output.

use anyhow::Result;

pub(crate) fn print_json<T: serde::Serialize>(v: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}
