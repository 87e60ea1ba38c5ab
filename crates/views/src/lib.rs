//! # mtcal-views
//!
//! What a person sees of mtcal, as pure functions from result documents to text: SVG
//! plots ([`plots`]). No IO, no async, no database: the server and the CLI hand in the
//! data and write the output where they need it.

pub mod plots;
