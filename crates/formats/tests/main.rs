//! The readers' tests, one binary: a module per file beside this one (one link, not one
//! per file), and the helpers they share.

mod common;

mod archive;
mod compensation;
mod compensation_reversal;
mod cost;
mod dialect;
mod drift;
mod fuzz;
mod positioning;
mod rotary;
mod session;
mod sniff;
mod units;
mod upload;
