//! The results (document + scalar columns for trend queries) and their figures:
//! [`Results`].

use crate::StoreFuture;
use crate::exclusion::SetAside;
use crate::machines::Machine;
pub use mtcal_api::results::{
    FIGURE_NAME_MAX, Figure, FigurePoint, ResultMeta, ResultScalars, ResultSummary, SkippedRow,
    StoredResult,
};
pub use mtcal_api::trends::CheckModel;
use serde_json::Value;

/// The results of the jobs (and of imports) and their named figures. Implementations
/// must make each method atomic.
pub trait Results: Send + Sync {
    fn get_result<'a>(&'a self, id: &'a str) -> StoreFuture<'a, StoredResult>;

    /// A machine's results of `kind` in time order (measured_at, then when each landed,
    /// then id: of two checks measured at the same time the later to land is the later).
    /// A stored row that does not decode (written by an older version, a null where a
    /// number belongs) is left out; [`Results::list_results_checked`] says which.
    fn list_results<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<ResultMeta>>;

    /// [`Results::list_results`] with the rows left out because they do not decode.
    fn list_results_checked<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, (Vec<ResultMeta>, Vec<SkippedRow>)>;

    /// For every machine with results of `kind`: baseline, latest and count.
    fn baseline_pairs<'a>(&'a self, kind: &'a str) -> StoreFuture<'a, Vec<BaselinePair>>;

    /// [`Results::baseline_pairs`] of a batch of machines: the first `limit` machines
    /// by id after `after` (None: from the first), in one read snapshot, so that a walk
    /// of the fleet costs a batch at a time, not one statement over every machine.
    fn baseline_pairs_after<'a>(
        &'a self,
        kind: &'a str,
        after: Option<&'a str>,
        limit: usize,
    ) -> StoreFuture<'a, PairBatch>;

    /// The named figures of a result ([`Figure`]), by name.
    fn result_figures<'a>(&'a self, result_id: &'a str) -> StoreFuture<'a, Vec<Figure>>;

    /// One figure of a machine's results in time order (measured_at, when it landed, id),
    /// whatever the result kind (ISO 230-2 figures come from `identification` and
    /// `standards` results alike).
    fn figure_trend<'a>(
        &'a self,
        machine_id: &'a str,
        name: &'a str,
    ) -> StoreFuture<'a, Vec<FigurePoint>>;

    /// The names of every figure stored for a machine, sorted.
    fn figure_names<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, Vec<String>>;

    /// Excludes a result from the history (kept, readable by id, recorded with who, when
    /// and why; left out of lists, trends and drift). Excluding an excluded result keeps
    /// the first record.
    fn exclude_result<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, ResultMeta>;

    /// Inserts a result without a job run (an `import` job, born succeeded).
    fn import_result<'a>(&'a self, r: NewResult) -> StoreFuture<'a, ResultMeta>;

    /// Inserts `r`, the explained model of check `original_id`, as [`Results::import_result`]
    /// does, claiming the check: one explained model per check. When one is stored
    /// already (another process stored it, even concurrently), nothing is stored and the
    /// answer is `None`, not an error.
    fn import_explained<'a>(
        &'a self,
        original_id: &'a str,
        r: NewResult,
    ) -> StoreFuture<'a, Option<ResultMeta>>;

    /// Inserts many results (each with its `import` job) in one transaction: for seeding
    /// benchmarks and bulk imports.
    fn import_results_bulk<'a>(&'a self, results: &'a [NewResult]) -> StoreFuture<'a, ()>;

    /// The stored check model ([`NewResult::check_model`]) of each of machine
    /// `machine_id`'s current results of `kind`, by result id (`None`: not known yet).
    /// Reads no document.
    fn check_models<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<(String, Option<CheckModel>)>>;

    /// The stored check model of result `id` (`None`: not known yet). Reads no document.
    fn check_model<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Option<CheckModel>>;

    /// Up to `limit` identifications whose check model is not known yet (stored before
    /// it was kept), by id.
    fn unknown_check_models<'a>(&'a self, limit: i64) -> StoreFuture<'a, Vec<String>>;

    /// Stores the check model of result `id`, learnt from its document.
    fn set_check_model<'a>(&'a self, id: &'a str, model: &'a CheckModel) -> StoreFuture<'a, ()>;
}

/// A result to store on completion of a job.
#[derive(Debug, Clone)]
pub struct NewResult {
    pub machine_id: String,
    pub dataset_id: Option<String>,
    pub kind: String,
    pub measured_at: String,
    pub document: Value,
    pub scalars: ResultScalars,
    /// Named scalar figures ([`Figure`]); empty for kinds that have none.
    pub figures: Vec<Figure>,
    /// The check's model as its document's misfit gate states it (an identification's;
    /// `None`: not known, read from the document when asked), kept in its own columns
    /// so listings read no document.
    pub check_model: Option<CheckModel>,
}

/// For the fleet ranking: each machine's baseline and latest identification scalars.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselinePair {
    pub machine: Machine,
    pub baseline: ResultMeta,
    pub latest: ResultMeta,
    pub results: i64,
}

/// A batch of the fleet's machines by id ([`Results::baseline_pairs_after`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PairBatch {
    /// The pairs of the batch's machines that have results of the kind, by machine id.
    pub pairs: Vec<BaselinePair>,
    /// How many machines the batch holds (fewer than asked: no machine after it).
    pub machines: usize,
    /// The batch's last machine (None: no machine after the one asked).
    pub last: Option<String>,
}
