//! Lenient numbers: serde_json writes a NaN or an infinity as `null`, and a file written before a
//! figure existed lacks its key. `#[serde(default = "nan::missing", deserialize_with =
//! "nan::read")]` on a field of type `f64` (or a `Vec`, `Option`, array or `(name, value)` pair
//! of them, nested) reads `null` as NaN and a missing key as NaN, an empty list or `None`.
//! Writing is untouched.

use serde::{Deserialize, Deserializer};

/// A number type with a value for `null` and for a missing key.
pub trait Lenient: Sized {
    /// The value of a missing key.
    fn missing() -> Self;
    /// Read a value, `null` numbers as NaN.
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error>;
}

/// `T` read leniently, inside a list or a pair.
struct L<T>(T);

impl<'de, T: Lenient> Deserialize<'de> for L<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        T::read(d).map(L)
    }
}

impl Lenient for f64 {
    fn missing() -> Self {
        f64::NAN
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

/// A list; `null` reads as an empty one.
impl<T: Lenient> Lenient for Vec<T> {
    fn missing() -> Self {
        Vec::new()
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Option::<Vec<L<T>>>::deserialize(d)?.unwrap_or_default();
        Ok(v.into_iter().map(|x| x.0).collect())
    }
}

impl<T: Lenient> Lenient for Option<T> {
    fn missing() -> Self {
        None
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Option::<L<T>>::deserialize(d)?.map(|x| x.0))
    }
}

/// A fixed-length list; a shorter one is padded with missing values.
impl<T: Lenient, const N: usize> Lenient for [T; N] {
    fn missing() -> Self {
        std::array::from_fn(|_| T::missing())
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut v = Vec::<T>::read(d)?.into_iter();
        Ok(std::array::from_fn(|_| v.next().unwrap_or_else(T::missing)))
    }
}

/// A named figure, `[name, value]`.
impl<T: Lenient> Lenient for (String, T) {
    fn missing() -> Self {
        (String::new(), T::missing())
    }
    fn read<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (name, L(v)) = <(String, L<T>)>::deserialize(d)?;
        Ok((name, v))
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

/// Counts of a fixed length, from a list that may be shorter (older files counted fewer
/// kinds): the rest are 0.
pub fn padded<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[usize; N], D::Error> {
    let mut v = Vec::<usize>::deserialize(d)?.into_iter();
    Ok(std::array::from_fn(|_| v.next().unwrap_or(0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_and_missing_read_as_nan() {
        #[derive(Deserialize)]
        struct T {
            #[serde(default = "missing", deserialize_with = "read")]
            a: f64,
            #[serde(default = "missing", deserialize_with = "read")]
            b: [f64; 3],
            #[serde(default = "missing", deserialize_with = "read")]
            c: Vec<f64>,
            #[serde(default = "missing", deserialize_with = "read")]
            d: Vec<(String, Vec<f64>)>,
            #[serde(default = "missing", deserialize_with = "read")]
            e: Option<Vec<f64>>,
        }
        let t: T =
            serde_json::from_str(r#"{"a": null, "b": [1.0, null], "d": [["x", [null, 2]]], "e": [null]}"#).unwrap();
        assert!(t.a.is_nan() && t.b[0] == 1.0 && t.b[1].is_nan() && t.b[2].is_nan() && t.c.is_empty());
        assert!(t.d[0].0 == "x" && t.d[0].1[0].is_nan() && t.d[0].1[1] == 2.0);
        assert!(t.e.is_some_and(|e| e[0].is_nan()));
        let t: T = serde_json::from_str(r#"{"c": [2, null], "e": null}"#).unwrap();
        assert!(t.a.is_nan() && t.c[0] == 2.0 && t.c[1].is_nan() && t.d.is_empty() && t.e.is_none());
    }

    #[test]
    fn short_counts_are_padded() {
        #[derive(Deserialize)]
        struct T {
            #[serde(deserialize_with = "padded")]
            n: [usize; 5],
        }
        let t: T = serde_json::from_str(r#"{"n": [1, 2, 3]}"#).unwrap();
        assert_eq!(t.n, [1, 2, 3, 0, 0]);
    }
}
