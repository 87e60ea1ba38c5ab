//! Who set a record aside and why: an exclusion of a result or a dataset, the deletion
//! of a dataset's bytes (shared by datasets and results).

pub use mtcal_api::datasets::Exclusion;

/// Who sets a record aside and why, as asked of the store (an exclusion of a result or a
/// dataset, the deletion of a dataset's bytes); checked by [`crate::text::check_record`].
/// The store adds the time and keeps it as an [`Exclusion`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SetAside<'a> {
    /// The API key (or the operator) that does it.
    pub by: &'a str,
    pub reason: &'a str,
}
