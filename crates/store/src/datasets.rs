//! The datasets (raw files with checksums): [`Datasets`].

use crate::StoreFuture;
use crate::exclusion::SetAside;
pub use mtcal_api::datasets::{Dataset, FileMeta};

/// The datasets uploaded for the machines: their files' bytes, excluded or deleted with a
/// record. Implementations must make each method atomic.
pub trait Datasets: Send + Sync {
    /// Stores a dataset and all its files in one transaction; an upload identical to one
    /// of the machine's datasets that is not excluded (same manifest checksum) is a
    /// [`crate::StoreError::Conflict`] naming the earlier dataset (uploading an excluded
    /// dataset's files again stores a new dataset).
    fn insert_dataset<'a>(&'a self, d: NewDataset) -> StoreFuture<'a, Dataset>;

    fn get_dataset<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Dataset>;

    /// The bytes of one file, as uploaded.
    fn dataset_file<'a>(&'a self, id: &'a str, name: &'a str) -> StoreFuture<'a, Vec<u8>>;

    /// Every file of a dataset, as uploaded.
    fn dataset_files<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Vec<(String, Vec<u8>)>>;

    /// A machine's datasets in time order (measured_at, uploaded_at, id); excluded ones (deleted
    /// ones included) only when `include_excluded`.
    fn list_datasets<'a>(
        &'a self,
        machine_id: &'a str,
        include_excluded: bool,
    ) -> StoreFuture<'a, Vec<Dataset>>;

    /// Excludes a dataset (recorded with who, when and why): no new job runs on it and
    /// every result computed from it is excluded with the same record, in one
    /// transaction (results excluded before keep their own record). A result that lands
    /// later from it is excluded as it lands. Excluding an excluded dataset keeps the
    /// first record. A job on it that is queued or running: [`crate::StoreError::Conflict`]
    /// naming the job (nothing changed).
    fn exclude_dataset<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, Dataset>;

    /// Deletes a dataset's raw bytes: the files' content is emptied, the dataset row and
    /// its files' names, sizes and checksums stay as a tombstone recorded with who, when
    /// and why. The dataset (its results with it) is excluded first with the same record
    /// when it was not. Deleting a deleted dataset keeps the first record. A job on it
    /// that is queued or running: [`crate::StoreError::Conflict`] naming the job.
    fn delete_dataset_files<'a>(
        &'a self,
        id: &'a str,
        why: SetAside<'a>,
    ) -> StoreFuture<'a, Dataset>;
}

/// A dataset to insert: metadata plus every file's bytes.
#[derive(Debug, Clone)]
pub struct NewDataset {
    pub machine_id: String,
    pub kind: String,
    pub measured_at: String,
    pub samples: i64,
    pub files: Vec<(String, Vec<u8>)>,
}
