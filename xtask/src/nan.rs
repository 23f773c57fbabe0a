//! Lenient numbers in the JSON files xtask writes and reads back (`BENCHMARKS.json`,
//! `target/bench/device.json`): `#[serde(default = "nan::missing", deserialize_with =
//! "nan::read")]` on a field of type `f64`, `[f64; N]` or `Vec<f64>` reads `null` (how
//! serde_json writes NaN and ±∞) as NaN and a missing key as NaN (an empty list for a `Vec`).

use serde::{Deserialize, Deserializer};

/// A number type with a value for `null` and for a missing key.
pub trait Lenient: Sized {
    fn missing() -> Self;
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error>;
}

impl Lenient for f64 {
    fn missing() -> Self {
        f64::NAN
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

impl Lenient for Vec<f64> {
    fn missing() -> Self {
        Vec::new()
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Option::<Vec<Option<f64>>>::deserialize(d)?.unwrap_or_default();
        Ok(v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
    }
}

impl<const N: usize> Lenient for [f64; N] {
    fn missing() -> Self {
        [f64::NAN; N]
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<f64>::read(d)?;
        Ok(std::array::from_fn(|i| v.get(i).copied().unwrap_or(f64::NAN)))
    }
}

impl<const N: usize> Lenient for Vec<[f64; N]> {
    fn missing() -> Self {
        Vec::new()
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Option::<Vec<Option<Vec<Option<f64>>>>>::deserialize(d)?.unwrap_or_default();
        Ok(v.into_iter()
            .map(|row| {
                let row = row.unwrap_or_default();
                std::array::from_fn(|i| row.get(i).copied().flatten().unwrap_or(f64::NAN))
            })
            .collect())
    }
}

/// A figure that was not measured (serialised only when it was).
pub fn absent(x: &f64) -> bool {
    x.is_nan()
}

/// The value of a missing key.
pub fn missing<T: Lenient>() -> T {
    T::missing()
}

/// Read a number, `null` as NaN.
pub fn read<'de, D: Deserializer<'de>, T: Lenient>(d: D) -> Result<T, D::Error> {
    T::read(d)
}
