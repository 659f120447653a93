//! JSON has no NaN: serde_json writes a NaN (a metric with nothing to average, e.g. the air time of a robot that
//! never stepped) as `null`. These read it back as NaN, so that a written ablation.json reads back unchanged.

use serde::{Deserialize, Deserializer};

pub fn f64<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

pub fn f64x3<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    Ok(<[Option<f64>; 3]>::deserialize(d)?.map(|x| x.unwrap_or(f64::NAN)))
}
