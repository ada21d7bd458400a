//! Generic grid search composing a stiction model and a linear identifier (filled by the
//! quantification work).
pub use linear_id;
pub use stiction_models;
