//! Test support of the truth suite: an independent session generator, the named truth
//! sessions and the scorer (docs/truth-suite.md).

pub mod cases;
pub mod generator;
pub mod known;
pub mod scorer;
