//! Exact serde for floats in checkpoints.
//!
//! serde_json's default float parser is "best effort" and may return a neighbouring double;
//! it also writes NaN and ±∞ as `null`. A resumed run must continue with exactly the numbers it
//! stopped with, so checkpoints store every state float as its IEEE-754 bit pattern (`u64`),
//! which JSON carries exactly.

/// `f64` as its bit pattern.
pub(crate) mod scalar {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(v.to_bits())
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        u64::deserialize(d).map(f64::from_bits)
    }
}

/// `Vec<f64>` as a sequence of bit patterns.
pub(crate) mod vec {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(v.iter().map(|x| x.to_bits()))
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Vec::<u64>::deserialize(d).map(|v| v.into_iter().map(f64::from_bits).collect())
    }
}
