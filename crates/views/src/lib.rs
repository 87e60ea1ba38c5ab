//! # mtcal-views
//!
//! What a person sees of mtcal, as pure functions from data to text: SVG plots
//! ([`plots`]), HTML pages ([`pages`], maud templates) and the static assets they use
//! ([`assets`], vendored). No IO, no async, no database: the server and the CLI hand in
//! the data and write the output where they need it.

pub mod assets;
pub mod pages;
pub mod plots;

pub use maud::{Markup, PreEscaped};
