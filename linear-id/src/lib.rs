//! Linear identifiers for the process block of the Hammerstein model (filled by the
//! linear-identification work: ARX, ARMAX, EARX, EARMAX, PARSIM-K).
