//! Bounds on what a client gives: the travel of a machine and the lengths of its text
//! fields. The store checks them before anything is stored and the API document's schemas
//! (the module `schemas`) state them.

/// Largest |travel end| of a machine accepted, mm (100 m: beyond any machine tool's axis).
pub const MAX_TRAVEL_MM: f64 = 100_000.0;

/// Longest identifier (machine id), characters.
pub const ID_MAX: usize = 64;
/// Longest machine name, characters.
pub const NAME_MAX: usize = 200;
/// Longest site, characters.
pub const SITE_MAX: usize = 100;
/// Longest tag, characters.
pub const TAG_MAX: usize = 64;
/// Most tags on one machine.
pub const TAGS_MAX: usize = 32;
/// Longest tag list as stored (a JSON array, UTF-8), bytes: below PostgreSQL's index row
/// limit of 2704 bytes with room for the row's header (32 ASCII tags of 64 characters,
/// or 12 of 64 CJK characters, fit; 14 of those did not).
pub const TAGS_BYTES_MAX: usize = 2400;
/// Longest tolerance profile target (a machine id or a tag), characters.
pub const TARGET_MAX: usize = 200;
/// Longest API key label, characters.
pub const LABEL_MAX: usize = 200;
/// Longest record of who did something (`key … (label)`), characters.
pub const BY_MAX: usize = 300;
/// Longest reason or comment, characters.
pub const REASON_MAX: usize = 1000;
