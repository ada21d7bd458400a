//! What a valve's diagnosed registrations agree on, as plain data: the diagnosis builds it
//! (`discrepancy::consensus`), the trend carries it (`monitoring::trend::ValveTrend::causes`).

use serde::ser::SerializeSeq;
use serde::{Serialize, Serializer};

/// The causes a valve's diagnosed registrations agree on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Consensus {
    /// Registrations diagnosed.
    pub registrations: usize,
    /// The causes named on more than half of them, with on how many, in order of count then
    /// name (empty: no cause holds on most registrations). In JSON, objects `{cause,
    /// registrations}`.
    #[serde(serialize_with = "held")]
    pub causes: Vec<(String, usize)>,
    /// The registrations whose causes differ from [`Consensus::causes`]: label, their causes
    /// and why, one phrase per cause missing or added.
    pub disagreeing: Vec<Disagreement>,
}

/// One registration whose causes differ from those of most registrations.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Disagreement {
    /// The registration's label.
    pub label: String,
    /// The causes it names.
    pub causes: Vec<String>,
    /// Why, in words with numbers: for each cause of the consensus it does not name, its
    /// likelihood ratio there against its threshold (or that it was not tested); for each cause
    /// it names beyond the consensus, the same.
    pub why: Vec<String>,
}

/// [`Consensus::causes`] as objects `{cause, registrations}`.
fn held<S: Serializer>(causes: &[(String, usize)], s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Held<'a> {
        cause: &'a str,
        registrations: usize,
    }
    let mut seq = s.serialize_seq(Some(causes.len()))?;
    for (cause, registrations) in causes {
        seq.serialize_element(&Held {
            cause,
            registrations: *registrations,
        })?;
    }
    seq.end()
}
