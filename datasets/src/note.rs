//! What the reader did to the data or noticed on the way in, typed: a [`Note`] has a
//! [`NoteKind`] that callers match on (for instance to say that gaps were filled) and a
//! sentence for people.

use std::fmt;

use serde::{Serialize, Serializer};

/// The kind of a reader's note.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum NoteKind {
    /// Which columns were used or ignored.
    Columns,
    /// How cells were read (decimal commas, ...).
    Format,
    /// Where the loop came from inside a file (a `.mat` struct path, time from Ts).
    Source,
    /// The controller-mode column: rows not in closed loop left out.
    Mode,
    /// Empty or NaN cells filled (interpolated or held).
    GapsFilled,
    /// Rows left out: gaps dropped, the longest regular or closed-loop segment kept.
    RowsDropped,
    /// Rows inserted for missing samples.
    RowsInserted,
    /// Irregular sampling treated as uniform.
    Jitter,
    /// Time stamps one sampling interval off the regular grid (written at a coarser
    /// resolution than the sampling), read in file order on the grid.
    Stamps,
    /// Flat stretches (historian compression or a frozen value).
    Flat,
    /// A column made of straight sloped segments with kinks between them: a historian's
    /// compressed storage read back by linear interpolation.
    Compression,
    /// OP's units and the valve span assumed.
    Units,
    /// The loop is integrating and was identified from MV to the PV increment.
    Integrating,
    /// Single-sample spikes found (replaced by the previous sample, or kept when too many).
    Spikes,
    /// A long record cut to its latest rows (`ReadOptions::window`).
    Window,
    /// PV or OP written on a lattice (counts, fixed decimals) coarse relative to its motion.
    Quantised,
}

impl NoteKind {
    /// Whether the note says samples were made up or left out (filled, inserted, dropped):
    /// evidence that the record is not what the historian logged.
    pub fn changes_samples(self) -> bool {
        matches!(
            self,
            NoteKind::GapsFilled
                | NoteKind::RowsDropped
                | NoteKind::RowsInserted
                | NoteKind::Spikes
        )
    }
}

/// One note of the reader.
#[derive(Debug, Clone, PartialEq)]
pub struct Note {
    /// What it is about.
    pub kind: NoteKind,
    /// The sentence, with numbers.
    pub text: String,
}

impl Note {
    /// A note of `kind` saying `text`.
    pub fn new(kind: NoteKind, text: impl Into<String>) -> Note {
        Note {
            kind,
            text: text.into(),
        }
    }
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

/// Serialised as its sentence (what JSON rows have always shown).
impl Serialize for Note {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A note equals the sentence it says (so tests and callers can compare with text).
impl PartialEq<&str> for Note {
    fn eq(&self, other: &&str) -> bool {
        self.text == *other
    }
}

impl PartialEq<String> for Note {
    fn eq(&self, other: &String) -> bool {
        &self.text == other
    }
}

impl Note {
    /// Whether the sentence contains `pat` (for messages and tests).
    pub fn contains(&self, pat: &str) -> bool {
        self.text.contains(pat)
    }
}
