//! Reading and writing the safetensors files we ship and checkpoint: named f32/f64/u64 arrays, written
//! atomically (temporary file in the same directory, fsync, rename), read back with every name, dtype and shape
//! checked and a clear error that names the file and the fix.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{bad_file, Error, Result};
use safetensors::tensor::{Dtype, TensorView};
use safetensors::SafeTensors;
use serde::de::DeserializeOwned;
use serde::Deserialize;

/// Named arrays to write.
#[derive(Default)]
pub struct Bundle {
    entries: Vec<(String, Dtype, Vec<usize>, Vec<u8>)>,
}

impl Bundle {
    pub fn add_f32(&mut self, name: &str, shape: &[usize], data: &[f32]) {
        assert_eq!(shape.iter().product::<usize>(), data.len(), "shape of {name}");
        self.entries.push((
            name.into(),
            Dtype::F32,
            shape.to_vec(),
            data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        ));
    }

    pub fn add_f64(&mut self, name: &str, shape: &[usize], data: &[f64]) {
        assert_eq!(shape.iter().product::<usize>(), data.len(), "shape of {name}");
        self.entries.push((
            name.into(),
            Dtype::F64,
            shape.to_vec(),
            data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        ));
    }

    pub fn add_u64(&mut self, name: &str, shape: &[usize], data: &[u64]) {
        assert_eq!(shape.iter().product::<usize>(), data.len(), "shape of {name}");
        self.entries.push((
            name.into(),
            Dtype::U64,
            shape.to_vec(),
            data.iter().flat_map(|x| x.to_le_bytes()).collect(),
        ));
    }

    /// Serialises to bytes (safetensors sorts by name; metadata goes in the header).
    pub fn to_bytes(&self, metadata: Option<HashMap<String, String>>) -> Result<Vec<u8>> {
        let views = self
            .entries
            .iter()
            .map(|(n, d, s, b)| Ok((n.clone(), TensorView::new(*d, s.clone(), b)?)))
            .collect::<Result<Vec<_>, safetensors::SafeTensorError>>()?;
        Ok(safetensors::serialize(views, metadata)?)
    }
}

/// Writes `bytes` to `path` atomically: a crash leaves either the old file or the new one, never a torn one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(Error::io("creating", dir))?;
    let name =
        path.file_name().ok_or_else(|| Error::Invalid(format!("{} names no file", path.display())))?.to_string_lossy();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    {
        let mut f = std::fs::File::create(&tmp).map_err(Error::io("creating", &tmp))?;
        f.write_all(bytes).map_err(Error::io("writing", &tmp))?;
        f.sync_all().map_err(Error::io("writing", &tmp))?;
    }
    std::fs::rename(&tmp, path).map_err(Error::io("renaming the new file to", path))?;
    // Make the rename itself durable.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// A safetensors file read into memory, with checked accessors.
pub struct Loaded {
    path: PathBuf,
    bytes: Vec<u8>,
}

impl Loaded {
    pub fn read(path: &Path) -> Result<Loaded> {
        let bytes = std::fs::read(path).map_err(Error::io("cannot read", path))?;
        Loaded::from_bytes(path, bytes)
    }

    /// Safetensors bytes already in memory (e.g. received from another rank); `origin` names them in errors.
    pub fn from_bytes(origin: &Path, bytes: Vec<u8>) -> Result<Loaded> {
        SafeTensors::deserialize(&bytes).map_err(|e| {
            Error::bad_file(format!(
                "{} is not a valid safetensors file ({e}): the file is corrupt or truncated",
                origin.display()
            ))
        })?;
        Ok(Loaded { path: origin.to_path_buf(), bytes })
    }

    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    fn view(&self, name: &str, dtype: Dtype, shape: &[usize]) -> Result<Vec<u8>> {
        let st = SafeTensors::deserialize(&self.bytes)
            .map_err(|e| Error::file(format!("{} is not a valid safetensors file", self.path.display()), e))?;
        let t = st.tensor(name).map_err(|_| {
            Error::bad_file(format!(
                "{} has no tensor '{name}': it was written by another version or for another network",
                self.path.display()
            ))
        })?;
        if t.dtype() != dtype || t.shape() != shape {
            bad_file!(
                "{}: tensor '{name}' is {:?} {:?}, expected {:?} {:?} (a network of another size?)",
                self.path.display(),
                t.dtype(),
                t.shape(),
                dtype,
                shape
            );
        }
        Ok(t.data().to_vec())
    }

    pub fn f32(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        let v: Vec<f32> = self
            .view(name, Dtype::F32, shape)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        if v.iter().any(|x| !x.is_finite()) {
            bad_file!("{}: tensor '{name}' holds non-finite values", self.path.display());
        }
        Ok(v)
    }

    pub fn f64(&self, name: &str, shape: &[usize]) -> Result<Vec<f64>> {
        Ok(self
            .view(name, Dtype::F64, shape)?
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }

    pub fn u64(&self, name: &str, shape: &[usize]) -> Result<Vec<u64>> {
        Ok(self
            .view(name, Dtype::U64, shape)?
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }

    /// The shape of a tensor, if present.
    pub fn shape(&self, name: &str) -> Option<Vec<usize>> {
        SafeTensors::deserialize(&self.bytes).ok()?.tensor(name).ok().map(|t| t.shape().to_vec())
    }
}

/// CRC-32 of a file's bytes, recorded in sidecars so a changed or damaged weights file is caught.
pub fn checksum(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// The fields by which every JSON sidecar we write names its format and its weights file.
#[derive(Deserialize)]
struct Header {
    format: String,
    version: u32,
    weights: String,
    weights_crc32: u32,
}

/// What a sidecar must be: its kind for messages ("checkpoint", "policy"), the format and version this build
/// reads, and a hint to add when the file cannot be read.
pub struct SidecarKind<'a> {
    pub kind: &'a str,
    pub format: &'a str,
    pub version: u32,
    pub hint: &'a str,
}

/// Reads a JSON sidecar and the safetensors file it names (beside it), validated in one way for every kind: the
/// format and version first (so an old or foreign file says so, not that a field is missing), then the fields,
/// then the weights' checksum.
pub fn read_sidecar<T: DeserializeOwned>(json: &Path, k: &SidecarKind) -> Result<(T, Loaded)> {
    let text = std::fs::read_to_string(json)
        .map_err(|e| Error::file(format!("cannot read {} {}{}", k.kind, json.display(), k.hint), e))?;
    let invalid = || format!("{} is not a valid {} sidecar", json.display(), k.kind);
    let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::file(invalid(), e))?;
    let h: Header = serde_json::from_value(value.clone()).map_err(|e| Error::file(invalid(), e))?;
    if h.format != k.format || h.version != k.version {
        bad_file!(
            "{} is a '{}' v{} file; this build reads '{}' v{}",
            json.display(),
            h.format,
            h.version,
            k.format,
            k.version
        );
    }
    let side: T = serde_json::from_value(value).map_err(|e| Error::file(invalid(), e))?;
    let weights = json.parent().unwrap_or(Path::new(".")).join(&h.weights);
    let loaded = Loaded::read(&weights)?;
    if checksum(loaded.bytes()) != h.weights_crc32 {
        bad_file!(
            "{} does not match the checksum in {}: the file is corrupt or was replaced",
            weights.display(),
            json.display()
        );
    }
    Ok((side, loaded))
}
