//! The store's story, told once and run against every backend: machines, datasets, the
//! queue's guarantees (exclusive claim, lease expiry, exactly-once completion, retries,
//! cancellation), results and keys.
//!
//! Each `async fn` below takes a fresh, empty store; [`stories!`] runs it on a temporary
//! SQLite file, and on PostgreSQL in a schema of its own when `MTCAL_TEST_PG` names a
//! server (else that half says it skipped).

use mtcal_store::*;
use serde_json::json;
use std::collections::BTreeMap;

/// A fresh SQLite store in a temporary directory (kept alive by the returned guard).
async fn sqlite() -> (tempfile::TempDir, SqliteStore) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.sqlite");
    let s = SqliteStore::open(path.to_str().unwrap()).await.unwrap();
    (dir, s)
}

/// One `#[tokio::test]` per backend for every story named.
macro_rules! stories {
    ($($story:ident),* $(,)?) => {
        mod on_sqlite {
            $(
                #[tokio::test]
                async fn $story() {
                    let (_dir, s) = super::sqlite().await;
                    super::$story(&s).await;
                }
            )*
        }
        mod on_postgres {
            $(
                #[tokio::test]
                async fn $story() {
                    let name = concat!("on_postgres::", stringify!($story));
                    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap()
                    else {
                        return;
                    };
                    let s = mtcal_store::PostgresStore::open(&pg.url).await.unwrap();
                    super::$story(&s).await;
                    pg.drop_schema().await.unwrap();
                }
            )*
        }
    };
}

stories!(
    machines_create_update_list,
    datasets_keep_bytes_and_reject_atomically,
    claim_is_exclusive_and_completion_happens_once,
    concurrent_claims_take_each_job_once,
    expired_lease_is_reaped_and_the_old_worker_cannot_finish,
    retries_wait_for_their_backoff_and_bad_input_fails_at_once,
    cancellation_of_queued_and_running_jobs,
    results_in_time_order_with_baseline,
    checks_measured_at_the_same_time_order_by_when_they_landed,
    figures_trend_by_name_and_bad_ones_store_nothing,
    keys_are_found_by_secret_only,
    keys_are_listed_and_a_revoked_key_authenticates_nothing,
    a_released_job_is_claimable_at_once_without_spending_an_attempt,
    migrations_are_all_applied,
    fleet_drift_is_ranked_and_an_older_computation_never_replaces_a_newer,
    tolerance_profiles_one_per_target_and_alerts_acknowledged_once,
    fleet_page_puts_alerted_machines_first_then_filters_sorts_and_counts,
    fleet_pages_equal_a_sort_of_every_machine_from_scratch,
    datasets_excluded_with_their_results_then_bytes_deleted_under_a_tombstone,
);

fn machine(id: &str) -> Machine {
    Machine {
        id: id.into(),
        name: format!("machine {id}"),
        topology: json!({"workpiece": ["X", "Y"], "tool": ["Z"]}),
        travel_mm: BTreeMap::from([("X".into(), [-100.0, 100.0])]),
        site: Some("plant 1".into()),
        tags: vec!["vmc".into()],
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    }
}

fn new_job(machine: &str) -> NewJob {
    NewJob {
        kind: JobKind::Identify,
        machine_id: Some(machine.into()),
        dataset_id: None,
        params: json!({}),
        max_attempts: 2,
    }
}

fn result(machine: &str, at: &str, ec0y: f64) -> NewResult {
    NewResult {
        check_model: None,
        machine_id: machine.into(),
        dataset_id: None,
        kind: "identification".into(),
        measured_at: at.into(),
        document: json!({"kind": "identification", "ec0y": ec0y}),
        scalars: ResultScalars {
            summary: ResultSummary {
                ec0y_urad: Some(ec0y),
                ..Default::default()
            },
            term_coefficients: BTreeMap::from([("EXX".into(), vec![0.01, 0.0, 0.0])]),
            ..Default::default()
        },
        figures: vec![],
    }
}

async fn machines_create_update_list(s: &dyn Store) {
    s.create_machine(&machine("M2")).await.unwrap();
    s.create_machine(&machine("M1")).await.unwrap();
    assert!(matches!(
        s.create_machine(&machine("M1")).await,
        Err(StoreError::Conflict(_))
    ));
    let m = s
        .update_machine(
            "M1",
            &MachinePatch {
                name: Some("renamed".into()),
                ..Default::default()
            },
        )
        .await
        .unwrap();
    assert_eq!(m.name, "renamed");
    assert_eq!(m.site.as_deref(), Some("plant 1"));
    let all = s.list_machines(None, 10).await.unwrap();
    assert_eq!(
        all.iter().map(|m| m.id.as_str()).collect::<Vec<_>>(),
        ["M1", "M2"]
    );
    assert_eq!(s.list_machines(Some("M1"), 10).await.unwrap().len(), 1);
    assert!(matches!(
        s.get_machine("nope").await,
        Err(StoreError::NotFound(_))
    ));
}

async fn datasets_keep_bytes_and_reject_atomically(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let files = vec![
        ("session.json".to_string(), b"{}".to_vec()),
        ("xy.csv.gz".to_string(), vec![0x1f, 0x8b, 0, 1, 2, 255]),
    ];
    let new = |files: Vec<(String, Vec<u8>)>| NewDataset {
        machine_id: "M1".into(),
        kind: "session".into(),
        measured_at: "2026-01-01T00:00:00Z".into(),
        samples: 3,
        files,
    };
    let d = s.insert_dataset(new(files.clone())).await.unwrap();
    assert_eq!(d.total_bytes, 8);
    assert_eq!(d.files.len(), 2);
    assert_eq!(
        s.dataset_file(&d.id, "xy.csv.gz").await.unwrap(),
        files[1].1
    );
    // The same file name twice: nothing of it is stored.
    let before = s.row_counts().await.unwrap();
    let dup = s
        .insert_dataset(new(vec![files[0].clone(), files[0].clone()]))
        .await;
    assert!(matches!(dup, Err(StoreError::Conflict(_))));
    assert_eq!(s.row_counts().await.unwrap(), before);
    // The same files again for the same machine: refused, naming the first dataset.
    let again = s.insert_dataset(new(files.clone())).await;
    match again {
        Err(StoreError::Conflict(m)) => assert!(m.contains(&d.id), "{m}"),
        other => panic!("expected a conflict, got {other:?}"),
    }
    assert_eq!(s.row_counts().await.unwrap(), before);
}

async fn claim_is_exclusive_and_completion_happens_once(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let j = s.enqueue(new_job("M1")).await.unwrap();
    assert_eq!(j.state, JobState::Queued);
    let a = s.claim_job("w1", 60_000).await.unwrap().unwrap();
    assert_eq!((a.id.as_str(), a.attempts), (j.id.as_str(), 1));
    assert!(s.claim_job("w2", 60_000).await.unwrap().is_none());
    // Another worker cannot complete it.
    assert!(matches!(
        s.complete_job(
            Lease::new(&j.id, "w2"),
            result("M1", "2026-01-01T00:00:00Z", 1.0)
        )
        .await,
        Err(StoreError::LeaseLost(_))
    ));
    let done = s
        .complete_job(
            Lease::new(&j.id, "w1"),
            result("M1", "2026-01-01T00:00:00Z", 1.0),
        )
        .await
        .unwrap();
    assert_eq!(done.state, JobState::Succeeded);
    assert!(
        s.complete_job(
            Lease::new(&j.id, "w1"),
            result("M1", "2026-01-01T00:00:00Z", 1.0)
        )
        .await
        .is_err()
    );
    assert_eq!(s.row_counts().await.unwrap().results, 1);
}

/// Four claimers drain 40 jobs at once (each claim on its own connection): every job is
/// claimed by exactly one of them.
async fn concurrent_claims_take_each_job_once(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let mut queued = Vec::new();
    for _ in 0..40 {
        queued.push(s.enqueue(new_job("M1")).await.unwrap().id);
    }
    let drain = |worker: &'static str| async move {
        let mut got = Vec::new();
        while let Some(j) = s.claim_job(worker, 60_000).await.unwrap() {
            assert_eq!(j.attempts, 1, "{} claimed twice", j.id);
            got.push(j.id);
        }
        got
    };
    let (a, b, c, d) = tokio::join!(drain("w1"), drain("w2"), drain("w3"), drain("w4"));
    let mut claimed: Vec<String> = [a, b, c, d].concat();
    claimed.sort();
    queued.sort();
    assert_eq!(claimed, queued);
}

async fn expired_lease_is_reaped_and_the_old_worker_cannot_finish(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let j = s.enqueue(new_job("M1")).await.unwrap();
    s.claim_job("dead", 1).await.unwrap().unwrap();
    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    assert_eq!(s.reap_expired().await.unwrap(), 1);
    assert_eq!(s.get_job(&j.id).await.unwrap().state, JobState::Queued);
    let again = s.claim_job("alive", 60_000).await.unwrap().unwrap();
    assert_eq!(again.attempts, 2);
    assert_eq!(
        s.heartbeat(
            Lease::new(&j.id, "dead"),
            1000,
            Progress {
                fraction: 0.5,
                message: "x"
            }
        )
        .await
        .unwrap(),
        Heartbeat::LeaseLost
    );
    assert!(
        s.complete_job(
            Lease::new(&j.id, "dead"),
            result("M1", "2026-01-01T00:00:00Z", 1.0)
        )
        .await
        .is_err()
    );
    s.complete_job(
        Lease::new(&j.id, "alive"),
        result("M1", "2026-01-01T00:00:00Z", 1.0),
    )
    .await
    .unwrap();
    // Out of attempts: a second expiry fails the job instead of requeueing it.
    let k = s.enqueue(new_job("M1")).await.unwrap();
    for _ in 0..2 {
        s.claim_job("dead", 1).await.unwrap().unwrap();
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        s.reap_expired().await.unwrap();
    }
    let k = s.get_job(&k.id).await.unwrap();
    assert_eq!(k.state, JobState::Failed);
    assert_eq!(k.error_code.as_deref(), Some("lease_expired"));
}

async fn retries_wait_for_their_backoff_and_bad_input_fails_at_once(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let j = s.enqueue(new_job("M1")).await.unwrap();
    s.claim_job("w", 60_000).await.unwrap().unwrap();
    let back = s
        .fail_job(
            Lease::new(&j.id, "w"),
            Failure {
                code: "transient",
                message: "busy",
                retry_after_ms: Some(60_000),
            },
        )
        .await
        .unwrap();
    assert_eq!(back.state, JobState::Queued);
    assert!(
        s.claim_job("w", 60_000).await.unwrap().is_none(),
        "claimed before its backoff elapsed"
    );
    let k = s.enqueue(new_job("M1")).await.unwrap();
    s.claim_job("w", 60_000).await.unwrap().unwrap();
    let f = s
        .fail_job(
            Lease::new(&k.id, "w"),
            Failure {
                code: "bad_input",
                message: "no planes",
                retry_after_ms: None,
            },
        )
        .await
        .unwrap();
    assert_eq!(f.state, JobState::Failed);
    assert_eq!(f.attempts, 1);
}

async fn cancellation_of_queued_and_running_jobs(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let q = s.enqueue(new_job("M1")).await.unwrap();
    assert_eq!(
        s.cancel_job(&q.id).await.unwrap().state,
        JobState::Cancelled
    );
    assert!(matches!(
        s.cancel_job(&q.id).await,
        Err(StoreError::Conflict(_))
    ));
    let r = s.enqueue(new_job("M1")).await.unwrap();
    s.claim_job("w", 60_000).await.unwrap().unwrap();
    assert_eq!(s.cancel_job(&r.id).await.unwrap().state, JobState::Running);
    assert_eq!(
        s.heartbeat(
            Lease::new(&r.id, "w"),
            60_000,
            Progress {
                fraction: 0.3,
                message: "solving"
            }
        )
        .await
        .unwrap(),
        Heartbeat::CancelRequested
    );
    assert!(
        s.complete_job(
            Lease::new(&r.id, "w"),
            result("M1", "2026-01-01T00:00:00Z", 1.0)
        )
        .await
        .is_err()
    );
    assert_eq!(
        s.finish_cancelled(Lease::new(&r.id, "w"))
            .await
            .unwrap()
            .state,
        JobState::Cancelled
    );
    assert_eq!(s.row_counts().await.unwrap().results, 0);
}

/// Two checks with the same `measured_at`: the one that landed first is the earlier (the
/// baseline), the one that landed last the latest, whatever their ids. Over eight
/// machines, an order by id alone would pass by chance once in 256 runs.
async fn checks_measured_at_the_same_time_order_by_when_they_landed(s: &dyn Store) {
    let at = "2026-05-01T08:00:00Z";
    let mut landed = vec![];
    for i in 0..8 {
        let m = format!("T{i}");
        s.create_machine(&machine(&m)).await.unwrap();
        let first = s.import_result(result(&m, at, 1.0)).await.unwrap();
        // Stored times are to the millisecond.
        tokio::time::sleep(std::time::Duration::from_millis(3)).await;
        let last = s.import_result(result(&m, at, 2.0)).await.unwrap();
        landed.push((m, first.id, last.id));
    }
    let pairs = s.baseline_pairs("identification").await.unwrap();
    for (m, first, last) in &landed {
        let p = pairs.iter().find(|p| &p.machine.id == m).unwrap();
        assert_eq!((&p.baseline.id, &p.latest.id), (first, last), "{m}");
        let list = s.list_results(m, "identification").await.unwrap();
        let ids: Vec<&String> = list.iter().map(|r| &r.id).collect();
        assert_eq!(ids, [first, last], "{m}");
    }
    // The same pairs walked in batches of 3 machines by id; a machine without results
    // is walked and has no pair.
    s.create_machine(&machine("T35")).await.unwrap();
    let (mut walked, mut after, mut sizes) = (vec![], None, vec![]);
    loop {
        let b = s
            .baseline_pairs_after("identification", after.as_deref(), 3)
            .await
            .unwrap();
        walked.extend(b.pairs);
        sizes.push(b.machines);
        if b.machines < 3 {
            assert_eq!(b.last.is_none(), b.machines == 0);
            break;
        }
        after = b.last;
    }
    assert_eq!(sizes, [3, 3, 3, 0]);
    assert_eq!(walked, pairs);
}

async fn results_in_time_order_with_baseline(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let late = s
        .import_result(result("M1", "2026-03-01T00:00:00Z", 3.0))
        .await
        .unwrap();
    let early = s
        .import_result(result("M1", "2026-01-01T00:00:00Z", 1.0))
        .await
        .unwrap();
    s.import_result(result("M1", "2026-02-01T00:00:00Z", 2.0))
        .await
        .unwrap();
    // Imports are born succeeded: nothing to claim.
    assert!(s.claim_job("w", 60_000).await.unwrap().is_none());
    let list = s.list_results("M1", "identification").await.unwrap();
    let ec: Vec<f64> = list
        .iter()
        .map(|r| r.scalars.summary.ec0y_urad.unwrap())
        .collect();
    assert_eq!(ec, [1.0, 2.0, 3.0]);
    let pairs = s.baseline_pairs("identification").await.unwrap();
    assert_eq!(pairs.len(), 1);
    assert_eq!(pairs[0].baseline.id, early.id);
    assert_eq!(pairs[0].latest.id, late.id);
    assert_eq!(pairs[0].results, 3);
    assert_eq!(
        pairs[0].latest.scalars.term_coefficients["EXX"],
        [0.01, 0.0, 0.0]
    );
    let b = list[1].id.clone();
    s.update_machine(
        "M1",
        &MachinePatch {
            baseline_result_id: Some(b.clone()),
            ..Default::default()
        },
    )
    .await
    .unwrap();
    assert_eq!(
        s.baseline_pairs("identification").await.unwrap()[0]
            .baseline
            .id,
        b
    );
    // Excluding the chosen baseline: the pair falls back to the first result; excluding
    // the latest: the latest left becomes it.
    let ex = s
        .exclude_result(
            &b,
            SetAside {
                by: "key k1",
                reason: "wrong probe",
            },
        )
        .await
        .unwrap();
    assert_eq!(ex.excluded.as_ref().unwrap().reason, "wrong probe");
    let again = s
        .exclude_result(
            &b,
            SetAside {
                by: "key k2",
                reason: "again",
            },
        )
        .await
        .unwrap();
    assert_eq!(again.excluded, ex.excluded, "the first record is kept");
    let list = s.list_results("M1", "identification").await.unwrap();
    assert_eq!(list.len(), 2);
    assert!(list.iter().all(|r| r.id != b));
    let p = &s.baseline_pairs("identification").await.unwrap()[0];
    assert_eq!(
        (p.baseline.id.as_str(), p.latest.id.as_str(), p.results),
        (early.id.as_str(), late.id.as_str(), 2)
    );
    s.exclude_result(
        &late.id,
        SetAside {
            by: "key k1",
            reason: "bad",
        },
    )
    .await
    .unwrap();
    let p = &s.baseline_pairs("identification").await.unwrap()[0];
    assert_eq!((p.latest.id.as_str(), p.results), (early.id.as_str(), 1));
    // Still readable by id, with the record.
    let kept = s.get_result(&late.id).await.unwrap();
    assert_eq!(kept.meta.excluded.unwrap().by, "key k1");
    assert!(matches!(
        s.exclude_result(
            "res_nope",
            SetAside {
                by: "k",
                reason: "r"
            }
        )
        .await,
        Err(StoreError::NotFound(_))
    ));
}

async fn figures_trend_by_name_and_bad_ones_store_nothing(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    s.create_machine(&machine("M2")).await.unwrap();
    let fig = |name: &str, value: f64, u: Option<f64>| Figure {
        name: name.into(),
        value,
        u,
    };
    let with = |machine: &str, at: &str, kind: &str, figures: Vec<Figure>| NewResult {
        check_model: None,
        kind: kind.into(),
        figures,
        ..result(machine, at, 0.0)
    };
    let late = s
        .import_result(with(
            "M1",
            "2026-03-01T00:00:00Z",
            "standards",
            vec![fig("iso230_2.X.E_um", 3.0, Some(0.1))],
        ))
        .await
        .unwrap();
    let early = s
        .import_result(with(
            "M1",
            "2026-01-01T00:00:00Z",
            "identification",
            vec![
                fig("iso230_2.X.E_um", 1.0, None),
                fig("iso230_4.XY.bi.H_um", 0.5, Some(0.02)),
            ],
        ))
        .await
        .unwrap();
    s.import_result(with(
        "M2",
        "2026-02-01T00:00:00Z",
        "identification",
        vec![fig("iso230_2.X.E_um", 9.0, None)],
    ))
    .await
    .unwrap();
    // In time order, across result kinds, one machine only.
    let t = s.figure_trend("M1", "iso230_2.X.E_um").await.unwrap();
    assert_eq!(
        t.iter()
            .map(|p| (p.result_id.as_str(), p.value, p.u))
            .collect::<Vec<_>>(),
        [
            (early.id.as_str(), 1.0, None),
            (late.id.as_str(), 3.0, Some(0.1))
        ]
    );
    assert!(
        s.figure_trend("M1", "iso230_2.Y.E_um")
            .await
            .unwrap()
            .is_empty()
    );
    assert_eq!(
        s.figure_names("M1").await.unwrap(),
        ["iso230_2.X.E_um", "iso230_4.XY.bi.H_um"]
    );
    let f = s.result_figures(&early.id).await.unwrap();
    assert_eq!(f[1], fig("iso230_4.XY.bi.H_um", 0.5, Some(0.02)));
    assert!(matches!(
        s.result_figures("res_none").await,
        Err(StoreError::NotFound(_))
    ));
    // A non-finite value, a negative uncertainty, a bad or repeated name: refused, and
    // nothing of the result is stored.
    let before = s.row_counts().await.unwrap();
    assert_eq!(before.result_figures, 4);
    for bad in [
        vec![fig("iso230_2.X.E_um", f64::NAN, None)],
        vec![fig("iso230_2.X.E_um", 1.0, Some(-0.1))],
        vec![fig("iso230_2.X.E_um", 1.0, Some(f64::INFINITY))],
        vec![fig("iso230_2.X.E um", 1.0, None)],
        vec![fig("", 1.0, None)],
        vec![fig("a", 1.0, None), fig("a", 2.0, None)],
    ] {
        let r = s
            .import_result(with("M1", "2026-04-01T00:00:00Z", "standards", bad))
            .await;
        assert!(matches!(r, Err(StoreError::Invalid(_))), "{r:?}");
    }
    assert_eq!(s.row_counts().await.unwrap(), before);
}

async fn keys_are_found_by_secret_only(s: &dyn Store) {
    let (k, secret) = s.create_key(Scope::Write, "ci").await.unwrap();
    assert_eq!(s.key_by_secret(&secret).await.unwrap().unwrap().id, k.id);
    assert!(s.key_by_secret("mtk_wrong").await.unwrap().is_none());
    let (other, other_secret) = s.create_key(Scope::Read, "other").await.unwrap();
    assert_ne!(other_secret, secret);
    let found = s.key_by_secret(&other_secret).await.unwrap().unwrap();
    assert_eq!((found.id, found.scope), (other.id, Scope::Read));
}

async fn keys_are_listed_and_a_revoked_key_authenticates_nothing(s: &dyn Store) {
    let (a, secret_a) = s.create_key(Scope::Write, "line 1").await.unwrap();
    let (b, secret_b) = s.create_key(Scope::Read, "dashboard").await.unwrap();
    let listed = s.list_keys().await.unwrap();
    assert_eq!(listed.len(), 2);
    assert!(listed.iter().all(|k| k.revoked_at.is_none()));
    assert!(listed.iter().any(|k| k.id == a.id && k.label == "line 1"));
    let revoked = s.revoke_key(&a.id).await.unwrap();
    let when = revoked.revoked_at.clone().expect("revocation time");
    assert!(s.key_by_secret(&secret_a).await.unwrap().is_none());
    assert_eq!(s.key_by_secret(&secret_b).await.unwrap().unwrap().id, b.id);
    // Revoking again keeps the first time; an unknown key is not found.
    assert_eq!(s.revoke_key(&a.id).await.unwrap().revoked_at, Some(when));
    assert!(matches!(
        s.revoke_key("key_nope").await,
        Err(StoreError::NotFound(_))
    ));
    let listed = s.list_keys().await.unwrap();
    assert_eq!(listed.iter().filter(|k| k.revoked_at.is_some()).count(), 1);
}

async fn a_released_job_is_claimable_at_once_without_spending_an_attempt(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let j = s.enqueue(new_job("M1")).await.unwrap();
    let a = s.claim_job("w1", 600_000).await.unwrap().unwrap();
    assert_eq!(a.attempts, 1);
    // Only the lease holder may hand it back.
    assert!(matches!(
        s.release_job(Lease::new(&j.id, "w2")).await,
        Err(StoreError::LeaseLost(_))
    ));
    let back = s.release_job(Lease::new(&j.id, "w1")).await.unwrap();
    assert_eq!((back.state, back.attempts), (JobState::Queued, 0));
    let counts = s.job_counts().await.unwrap();
    assert_eq!(counts.len(), 1, "{counts:?}");
    assert_eq!(
        (counts[0].state.as_str(), counts[0].count),
        ("queued", 1),
        "{counts:?}"
    );
    // Claimable at once by another worker (the lease of 10 minutes is not waited for).
    let b = s.claim_job("w2", 60_000).await.unwrap().unwrap();
    assert_eq!((b.id.as_str(), b.attempts), (j.id.as_str(), 1));
    // The first worker can no longer finish it.
    assert!(matches!(
        s.complete_job(
            Lease::new(&j.id, "w1"),
            result("M1", "2026-01-01T00:00:00Z", 1.0)
        )
        .await,
        Err(StoreError::LeaseLost(_))
    ));
    s.complete_job(
        Lease::new(&j.id, "w2"),
        result("M1", "2026-01-01T00:00:00Z", 1.0),
    )
    .await
    .unwrap();
    assert_eq!(s.row_counts().await.unwrap().results, 1);
    // A running job whose cancellation was asked for is cancelled when handed back.
    let k = s.enqueue(new_job("M1")).await.unwrap();
    s.claim_job("w1", 60_000).await.unwrap().unwrap();
    s.cancel_job(&k.id).await.unwrap();
    assert_eq!(
        s.release_job(Lease::new(&k.id, "w1")).await.unwrap().state,
        JobState::Cancelled
    );
}

async fn fleet_drift_is_ranked_and_an_older_computation_never_replaces_a_newer(s: &dyn Store) {
    for id in ["M1", "M2", "M3"] {
        s.create_machine(&machine(id)).await.unwrap();
    }
    let row = |id: &str, at: i64, um: f64, urad: f64| FleetDriftRow {
        machine_id: id.into(),
        read_at_ms: at,
        drift_um: um,
        drift_urad: urad,
        entry: EntryJson::new(&serde_json::json!({"machine_id": id, "drift_um": um})).unwrap(),
        latest_measured_at: Some(format!("2026-0{}-01T00:00:00Z", 1 + at % 9)),
        basis: Some(format!("b{at}")),
    };
    assert!(s.put_fleet_drift(&row("M1", 10, 3.0, 1.0)).await.unwrap());
    assert!(s.put_fleet_drift(&row("M2", 10, 5.0, 0.5)).await.unwrap());
    assert!(s.put_fleet_drift(&row("M3", 10, 1.0, 9.0)).await.unwrap());
    let ids = |v: Vec<(FleetDriftRow, String, Option<String>)>| {
        v.into_iter()
            .map(|(r, _, _)| r.machine_id)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        ids(s.fleet_drift_ranked(true, 10).await.unwrap()),
        ["M2", "M1", "M3"]
    );
    assert_eq!(
        ids(s.fleet_drift_ranked(false, 2).await.unwrap()),
        ["M3", "M1"]
    );
    // A computation from an older read is ignored; a newer one replaces.
    assert!(!s.put_fleet_drift(&row("M2", 9, 0.0, 0.0)).await.unwrap());
    assert!(s.put_fleet_drift(&row("M1", 11, 7.0, 1.0)).await.unwrap());
    let ranked = s.fleet_drift_ranked(true, 10).await.unwrap();
    assert_eq!(ids(ranked.clone()), ["M1", "M2", "M3"]);
    assert_eq!(ranked[1].0.drift_um, 5.0);
    let entry: serde_json::Value = ranked[0].0.entry.decode().unwrap();
    assert_eq!(entry["drift_um"], 7.0);
    assert_eq!(ranked[0].1, "machine M1", "the machine's current name");
    // A removal from an older read, or one as old, leaves the row; a later one removes.
    assert!(!s.delete_fleet_drift("M1", 10).await.unwrap());
    assert!(!s.delete_fleet_drift("M1", 11).await.unwrap());
    assert_eq!(s.fleet_drift_ranked(true, 10).await.unwrap().len(), 3);
    assert!(s.delete_fleet_drift("M1", 12).await.unwrap());
    assert_eq!(
        ids(s.fleet_drift_ranked(true, 10).await.unwrap()),
        ["M2", "M3"]
    );
    // Many rows in one transaction, each kept only if not older than the stored one.
    let stored = s
        .put_fleet_drifts(&[
            row("M1", 12, 2.0, 2.0),
            row("M2", 9, 8.0, 8.0),
            row("M3", 12, 4.0, 4.0),
        ])
        .await
        .unwrap();
    assert_eq!(stored, 2, "M2's older computation ignored");
    let ranked = s.fleet_drift_ranked(true, 10).await.unwrap();
    assert_eq!(ids(ranked.clone()), ["M2", "M3", "M1"]);
    assert_eq!(ranked[0].0, row("M2", 10, 5.0, 0.5), "read back whole");
    let bases = s.fleet_drift_bases(None, None).await.unwrap();
    assert_eq!(
        bases,
        [
            ("M1".to_string(), Some("b12".to_string())),
            ("M2".into(), Some("b10".into())),
            ("M3".into(), Some("b12".into())),
        ]
    );
    // A batch of the refresh's walk: after M1, up to M2; after M2, to the end.
    assert_eq!(
        s.fleet_drift_bases(Some("M1"), Some("M2")).await.unwrap(),
        bases[1..2]
    );
    assert_eq!(
        s.fleet_drift_bases(Some("M2"), None).await.unwrap(),
        bases[2..]
    );
}

async fn tolerance_profiles_one_per_target_and_alerts_acknowledged_once(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let profile = |id: &str, scope: &str, target: &str| ToleranceProfile {
        id: id.into(),
        scope: scope.into(),
        target: target.into(),
        limits: json!({"terms": {"EXX": 5.0}, "drift_um": 2.0}),
        webhook_url: None,
        webhook_secret: None,
        created_at: String::new(),
        updated_at: String::new(),
    };
    let p = s
        .create_tolerance(&profile("tol_1", "machine", "M1"))
        .await
        .unwrap();
    assert_eq!(p.limits["terms"]["EXX"], 5.0);
    assert!(!p.created_at.is_empty());
    s.create_tolerance(&profile("tol_2", "tag", "vmc"))
        .await
        .unwrap();
    // One profile per (scope, target); the same target in the other scope is another.
    let e = s
        .create_tolerance(&profile("tol_3", "machine", "M1"))
        .await
        .unwrap_err();
    assert!(
        matches!(&e, StoreError::Conflict(m) if m.contains("machine M1")),
        "{e}"
    );
    s.create_tolerance(&profile("tol_4", "tag", "M1"))
        .await
        .unwrap();
    let all: Vec<(String, String)> = s
        .list_tolerances()
        .await
        .unwrap()
        .into_iter()
        .map(|p| (p.scope, p.target))
        .collect();
    assert_eq!(
        all,
        [
            ("machine".to_string(), "M1".to_string()),
            ("tag".into(), "M1".into()),
            ("tag".into(), "vmc".into())
        ]
    );
    let u = s
        .update_tolerance(&ToleranceProfile {
            limits: json!({"drift_um": 3.0}),
            webhook_url: Some("http://127.0.0.1:9/hook".into()),
            webhook_secret: Some("whsec_0123456789abcdef".into()),
            ..s.get_tolerance("tol_2").await.unwrap()
        })
        .await
        .unwrap();
    assert_eq!(u.limits, json!({"drift_um": 3.0}));
    assert_eq!(u.webhook_url.as_deref(), Some("http://127.0.0.1:9/hook"));
    assert_eq!(u.webhook_secret.as_deref(), Some("whsec_0123456789abcdef"));
    assert!(
        !format!("{u:?}").contains("0123456789abcdef")
            && !serde_json::to_string(&u)
                .unwrap()
                .contains("0123456789abcdef"),
        "a webhook secret is never printed or serialised"
    );
    assert!(matches!(
        s.update_tolerance(&ToleranceProfile {
            id: "nope".into(),
            ..u.clone()
        })
        .await,
        Err(StoreError::NotFound(_))
    ));
    s.delete_tolerance("tol_4").await.unwrap();
    assert!(matches!(
        s.get_tolerance("tol_4").await,
        Err(StoreError::NotFound(_))
    ));
    assert!(matches!(
        s.delete_tolerance("tol_4").await,
        Err(StoreError::NotFound(_))
    ));

    // Jobs newest first, filtered by state (the dashboard's jobs page).
    let j1 = s.enqueue(new_job("M1")).await.unwrap();
    let j2 = s.enqueue(new_job("M1")).await.unwrap();
    s.cancel_job(&j1.id).await.unwrap();
    let listed: Vec<String> = s
        .list_jobs(None, 10)
        .await
        .unwrap()
        .into_iter()
        .map(|j| j.id)
        .collect();
    assert_eq!(listed, [j2.id.clone(), j1.id.clone()]);
    let queued = s.list_jobs(Some(JobState::Queued), 10).await.unwrap();
    assert_eq!(queued.len(), 1);
    assert_eq!(queued[0].id, j2.id);
    assert_eq!(s.list_jobs(None, 1).await.unwrap().len(), 1);

    // Alerts: one per landed result; listed newest first; filtered; acknowledged once.
    let r1 = s
        .import_result(result("M1", "2026-01-01T00:00:00Z", 1.0))
        .await
        .unwrap();
    let r2 = s
        .import_result(result("M1", "2026-02-01T00:00:00Z", 9.0))
        .await
        .unwrap();
    let alert = |id: &str, result: &str, at: &str| Alert {
        raised: AlertRaised {
            id: id.into(),
            machine_id: "M1".into(),
            result_id: result.into(),
            baseline_result_id: r1.id.clone(),
            profile_id: "tol_1".into(),
            raised_at: at.into(),
            message: "EXX changed".into(),
        },
        items: json!([{"item": "EXX"}]),
        details: Some(json!({"measured_at": at})),
        acknowledged_at: None,
        acknowledged_by: None,
        acknowledgement_comment: None,
    };
    let a1 = s
        .raise_alert(&alert("al_1", &r1.id, "2026-03-01T00:00:00Z"), &[])
        .await
        .unwrap()
        .unwrap();
    assert_eq!(a1.items[0]["item"], "EXX");
    assert_eq!(
        a1.details,
        Some(json!({"measured_at": "2026-03-01T00:00:00Z"}))
    );
    assert_eq!(a1.acknowledgement_comment, None);
    // The same result again (a job run twice) raises nothing more.
    assert!(
        s.raise_alert(&alert("al_x", &r1.id, "2026-03-02T00:00:00Z"), &[])
            .await
            .unwrap()
            .is_none()
    );
    s.raise_alert(&alert("al_2", &r2.id, "2026-03-03T00:00:00Z"), &[])
        .await
        .unwrap()
        .unwrap();
    let ids = |v: Vec<Alert>| v.into_iter().map(|a| a.raised.id).collect::<Vec<_>>();
    assert_eq!(
        ids(s.list_alerts(None, None, 10).await.unwrap()),
        ["al_2", "al_1"]
    );
    assert_eq!(
        ids(s.list_alerts(Some("M1"), None, 1).await.unwrap()),
        ["al_2"]
    );
    assert!(
        s.list_alerts(Some("M2"), None, 10)
            .await
            .unwrap()
            .is_empty()
    );
    let acked = s
        .acknowledge_alert("al_1", "key k1 (ops)", Some("spindle replaced — «ok»"))
        .await
        .unwrap();
    assert_eq!(acked.acknowledged_by.as_deref(), Some("key k1 (ops)"));
    assert_eq!(
        acked.acknowledgement_comment.as_deref(),
        Some("spindle replaced — «ok»")
    );
    let first = acked.acknowledged_at.clone().unwrap();
    let again = s
        .acknowledge_alert("al_1", "key k2 (other)", Some("again"))
        .await
        .unwrap();
    assert_eq!(again.acknowledged_at.as_deref(), Some(first.as_str()));
    assert_eq!(again.acknowledged_by.as_deref(), Some("key k1 (ops)"));
    assert_eq!(
        again.acknowledgement_comment.as_deref(),
        Some("spindle replaced — «ok»"),
        "the first acknowledgement is kept, with its comment"
    );
    assert_eq!(
        ids(s.list_alerts(None, Some(true), 10).await.unwrap()),
        ["al_2"]
    );
    assert_eq!(
        ids(s.list_alerts(Some("M1"), Some(false), 10).await.unwrap()),
        ["al_1"]
    );
    assert!(matches!(
        s.acknowledge_alert("nope", "x", None).await,
        Err(StoreError::NotFound(_))
    ));
}

async fn fleet_page_puts_alerted_machines_first_then_filters_sorts_and_counts(s: &dyn Store) {
    let mk = |id: &str, site: &str, tags: &[&str]| Machine {
        site: Some(site.into()),
        tags: tags.iter().map(|t| t.to_string()).collect(),
        ..machine(id)
    };
    s.create_machine(&mk("A", "north", &["vmc"])).await.unwrap();
    s.create_machine(&mk("B", "north", &["5_axis"]))
        .await
        .unwrap();
    s.create_machine(&mk("C", "south", &["vmc", "50%"]))
        .await
        .unwrap();
    s.create_machine(&mk("D", "south", &["5xaxis"]))
        .await
        .unwrap();
    let row = |id: &str, um: f64, urad: f64, at: &str| FleetDriftRow {
        machine_id: id.into(),
        read_at_ms: 1,
        drift_um: um,
        drift_urad: urad,
        entry: EntryJson::new(&json!({"machine_id": id})).unwrap(),
        latest_measured_at: Some(at.into()),
        basis: None,
    };
    s.put_fleet_drift(&row("A", 1.0, 9.0, "2026-03-01T00:00:00Z"))
        .await
        .unwrap();
    s.put_fleet_drift(&row("B", 5.0, 1.0, "2026-01-01T00:00:00Z"))
        .await
        .unwrap();
    s.put_fleet_drift(&row("C", 3.0, 2.0, "2026-02-01T00:00:00Z"))
        .await
        .unwrap();
    // D has no identification: no drift row, listed last by drift, with its latest
    // check of another kind that is not excluded.
    let cradle = |at: &str| NewResult {
        check_model: None,
        kind: "cradle".into(),
        ..result("D", at, 0.0)
    };
    let kept = s
        .import_result(cradle("2026-02-01T00:00:00Z"))
        .await
        .unwrap();
    let later = s
        .import_result(cradle("2026-03-01T00:00:00Z"))
        .await
        .unwrap();
    s.exclude_result(
        &later.id,
        SetAside {
            by: "key k1 (ops)",
            reason: "probe dropped",
        },
    )
    .await
    .unwrap();
    let q = |sort, site: Option<&str>, tag: Option<&str>| FleetPageQuery {
        site: site.map(Into::into),
        tag: tag.map(Into::into),
        sort,
        offset: 0,
        limit: 10,
        within_sites: vec![],
        within_tags: vec![],
    };
    let ids = |p: &FleetPage| {
        p.rows
            .iter()
            .map(|r| r.machine.id.clone())
            .collect::<Vec<_>>()
    };
    let p = s
        .fleet_page(&q(FleetSort::DriftUm, None, None))
        .await
        .unwrap();
    assert_eq!(ids(&p), ["B", "C", "A", "D"]);
    assert_eq!(p.total, 4);
    assert_eq!(p.sites, ["north", "south"]);
    assert_eq!(p.tags, ["50%", "5_axis", "5xaxis", "vmc"]);
    assert!(p.rows[3].drift.is_none());
    assert_eq!(
        p.rows[3].other_check,
        Some(LastCheck {
            result_id: kept.id.clone(),
            kind: "cradle".into(),
            measured_at: kept.measured_at.clone(),
        }),
        "the latest check that is not excluded"
    );
    assert!(
        p.rows[..3].iter().all(|r| r.other_check.is_none()),
        "a machine with a drift row names its latest identification there"
    );
    assert_eq!(
        p.rows[0].drift,
        Some(row("B", 5.0, 1.0, "2026-01-01T00:00:00Z")),
        "the page's rows read whole"
    );
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::DriftUrad, None, None))
            .await
            .unwrap()),
        ["A", "C", "B", "D"]
    );
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::LastCheck, None, None))
            .await
            .unwrap()),
        ["A", "C", "B", "D"]
    );
    assert_eq!(
        ids(&s.fleet_page(&q(FleetSort::Name, None, None)).await.unwrap()),
        ["A", "B", "C", "D"]
    );
    // Filters: site; tag matched whole, LIKE's wildcards taken literally.
    let p = s
        .fleet_page(&q(FleetSort::DriftUm, Some("south"), None))
        .await
        .unwrap();
    assert_eq!((ids(&p), p.total), (vec!["C".to_string(), "D".into()], 2));
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::Name, None, Some("vmc")))
            .await
            .unwrap()),
        ["A", "C"]
    );
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::Name, None, Some("5_axis")))
            .await
            .unwrap()),
        ["B"]
    );
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::Name, None, Some("50%")))
            .await
            .unwrap()),
        ["C"]
    );
    assert!(
        s.fleet_page(&q(FleetSort::Name, None, Some("vm")))
            .await
            .unwrap()
            .rows
            .is_empty()
    );
    // A machine with an active alert comes first; an acknowledged one does not count.
    let r = s
        .import_result(result("A", "2026-03-01T00:00:00Z", 1.0))
        .await
        .unwrap();
    let alert = |id: &str| Alert {
        raised: AlertRaised {
            id: id.into(),
            machine_id: "A".into(),
            result_id: r.id.clone(),
            baseline_result_id: r.id.clone(),
            profile_id: "p".into(),
            raised_at: "2026-03-02T00:00:00Z".into(),
            message: "m".into(),
        },
        items: json!([]),
        details: None,
        acknowledged_at: None,
        acknowledged_by: None,
        acknowledgement_comment: None,
    };
    s.raise_alert(&alert("al_1"), &[]).await.unwrap();
    let p = s
        .fleet_page(&q(FleetSort::DriftUm, None, None))
        .await
        .unwrap();
    assert_eq!(ids(&p), ["A", "B", "C", "D"]);
    assert_eq!(p.rows[0].active_alerts, 1);
    // Paging.
    let mut page2 = q(FleetSort::DriftUm, None, None);
    (page2.offset, page2.limit) = (1, 2);
    let p = s.fleet_page(&page2).await.unwrap();
    assert_eq!((ids(&p), p.total), (vec!["B".to_string(), "C".into()], 4));
    s.acknowledge_alert("al_1", "x", None).await.unwrap();
    assert_eq!(
        ids(&s
            .fleet_page(&q(FleetSort::DriftUm, None, None))
            .await
            .unwrap()),
        ["B", "C", "A", "D"]
    );
}

/// Every page of every order and filter equals the slice of one sort of all the
/// machines written here from the page's rule (active alerts first, then the key largest
/// first with the machines lacking it last, ties by id), over a fleet built to have ties
/// in every key, machines without a drift row or without a check time, alerted machines
/// (one with two alerts, one whose only alert is acknowledged) and pages that straddle
/// each boundary (alerted, keyed, lacking the key).
async fn fleet_pages_equal_a_sort_of_every_machine_from_scratch(s: &dyn Store) {
    struct Truth {
        id: String,
        site: String,
        tags: Vec<String>,
        row: Option<(f64, f64, Option<String>)>,
        alerts: i64,
    }
    let mut fleet = Vec::new();
    for i in 0..23_usize {
        let id = format!("M{i:02}");
        let site = ["north", "south", "east"][i % 3].to_string();
        let tags: Vec<String> = match i % 4 {
            0 => vec!["vmc".into()],
            1 => vec!["hmc".into()],
            2 => vec!["vmc".into(), "5_axis".into()],
            _ => vec![],
        };
        s.create_machine(&Machine {
            site: Some(site.clone()),
            tags: tags.clone(),
            ..machine(&id)
        })
        .await
        .unwrap();
        // Few distinct values: ties in every key. Every fifth machine has no drift row,
        // every seventh row no check time (written by an older version).
        let row = (i % 5 != 4).then(|| {
            (
                [1.5, 0.5, 2.5][i % 3],
                [3.0, 1.0][i % 2],
                (i % 7 != 3).then(|| format!("2026-0{}-01T00:00:00Z", 1 + i % 4)),
            )
        });
        if let Some((um, urad, at)) = &row {
            s.put_fleet_drift(&FleetDriftRow {
                machine_id: id.clone(),
                read_at_ms: 1,
                drift_um: *um,
                drift_urad: *urad,
                entry: EntryJson::new(&json!({"machine_id": id})).unwrap(),
                latest_measured_at: at.clone(),
                basis: None,
            })
            .await
            .unwrap();
        }
        fleet.push(Truth {
            id,
            site,
            tags,
            row,
            alerts: 0,
        });
    }
    // Alerts: two active on M05, one on M04 (no drift row), M10 (no check time) and M17,
    // one acknowledged on M07 (counts as none).
    for (n, machine_id) in ["M05", "M05", "M04", "M10", "M17", "M07"]
        .into_iter()
        .enumerate()
    {
        let r = s
            .import_result(result(
                machine_id,
                &format!("2026-05-0{}T00:00:00Z", n + 1),
                1.0,
            ))
            .await
            .unwrap();
        let id = format!("al_{n}");
        s.raise_alert(
            &Alert {
                raised: AlertRaised {
                    id: id.clone(),
                    machine_id: machine_id.into(),
                    result_id: r.id.clone(),
                    baseline_result_id: r.id,
                    profile_id: "p".into(),
                    raised_at: "2026-05-09T00:00:00Z".into(),
                    message: "m".into(),
                },
                items: json!([]),
                details: None,
                acknowledged_at: None,
                acknowledged_by: None,
                acknowledgement_comment: None,
            },
            &[],
        )
        .await
        .unwrap();
        if machine_id == "M07" {
            s.acknowledge_alert(&id, "x", None).await.unwrap();
        } else {
            fleet
                .iter_mut()
                .find(|m| m.id == machine_id)
                .unwrap()
                .alerts += 1;
        }
    }
    type Key = fn(&Truth) -> Option<String>;
    // Each key as a string that sorts as the key does (the values are small, positive
    // and written with one decimal; check times are RFC 3339 of one format).
    let sorts: [(FleetSort, Key); 4] = [
        (FleetSort::DriftUm, |m| {
            m.row.as_ref().map(|r| format!("{:05.1}", r.0))
        }),
        (FleetSort::DriftUrad, |m| {
            m.row.as_ref().map(|r| format!("{:05.1}", r.1))
        }),
        (FleetSort::LastCheck, |m| {
            m.row.as_ref().and_then(|r| r.2.clone())
        }),
        (FleetSort::Name, |_| Some(String::new())),
    ];
    let filters = [
        (None, None),
        (Some("north"), None),
        (None, Some("vmc")),
        (Some("south"), Some("vmc")),
        (None, Some("5_axis")),
        (Some("west"), None),
    ];
    for (sort, key) in sorts {
        for (site, tag) in filters {
            let mut expected: Vec<&Truth> = fleet
                .iter()
                .filter(|m| site.is_none_or(|s| m.site == s))
                .filter(|m| tag.is_none_or(|t| m.tags.iter().any(|x| x == t)))
                .collect();
            expected.sort_by(|a, b| {
                (b.alerts > 0)
                    .cmp(&(a.alerts > 0))
                    .then_with(|| match (key(a), key(b)) {
                        (Some(x), Some(y)) => y.cmp(&x),
                        (x, y) => y.is_some().cmp(&x.is_some()),
                    })
                    .then_with(|| a.id.cmp(&b.id))
            });
            let what = format!("{sort:?} site {site:?} tag {tag:?}");
            for limit in [1, 4, 7, 100] {
                let mut seen = Vec::new();
                for offset in (0..expected.len() + limit).step_by(limit) {
                    let p = s
                        .fleet_page(&FleetPageQuery {
                            site: site.map(Into::into),
                            tag: tag.map(Into::into),
                            sort,
                            offset: offset as i64,
                            limit: limit as i64,
                            within_sites: vec![],
                            within_tags: vec![],
                        })
                        .await
                        .unwrap();
                    assert_eq!(p.total, expected.len() as i64, "{what}");
                    let want: Vec<_> = expected.iter().skip(offset).take(limit).collect();
                    assert_eq!(
                        p.rows
                            .iter()
                            .map(|r| (r.machine.id.as_str(), r.active_alerts, r.drift.is_some()))
                            .collect::<Vec<_>>(),
                        want.iter()
                            .map(|m| (m.id.as_str(), m.alerts, m.row.is_some()))
                            .collect::<Vec<_>>(),
                        "{what}, limit {limit}, offset {offset}"
                    );
                    seen.extend(p.rows.into_iter().map(|r| r.machine.id));
                }
                assert_eq!(seen.len(), expected.len(), "{what}: every machine once");
            }
        }
    }
}

async fn migrations_are_all_applied(s: &dyn Store) {
    assert_eq!(s.pending_migrations().await.unwrap(), Vec::<i64>::new());
}

/// The secret of a key appears nowhere in the SQLite files (database and write-ahead log).
#[tokio::test]
async fn sqlite_keeps_no_key_secret() {
    let (dir, s) = sqlite().await;
    let (_, secret) = s.create_key(Scope::Admin, "ops").await.unwrap();
    let mut bytes = Vec::new();
    for e in std::fs::read_dir(dir.path()).unwrap() {
        bytes.extend(std::fs::read(e.unwrap().path()).unwrap());
    }
    let hash = keys::hash_secret(&secret);
    let has = |needle: &str| bytes.windows(needle.len()).any(|w| w == needle.as_bytes());
    assert!(has(&hash), "the hash is stored, so the scan reads the data");
    assert!(!has(&secret[4..]));
}

#[tokio::test]
async fn sqlite_deleted_dataset_bytes_leave_the_disk() {
    let (dir, s) = sqlite().await;
    s.create_machine(&machine("M1")).await.unwrap();
    // Distinct markers, one in an overflow chain (larger than a page) and one small.
    let big: Vec<u8> = (0..20_000u32)
        .flat_map(|i| format!("big-{i:05};").into_bytes())
        .collect();
    let d = s
        .insert_dataset(NewDataset {
            machine_id: "M1".into(),
            kind: "session".into(),
            measured_at: "2026-01-01T00:00:00Z".into(),
            samples: 1,
            files: vec![
                ("session.json".to_string(), b"small-marker-7f3a".to_vec()),
                ("xy.csv".to_string(), big),
            ],
        })
        .await
        .unwrap();
    let on_disk = || {
        let mut bytes = Vec::new();
        for e in std::fs::read_dir(dir.path()).unwrap() {
            bytes.extend(std::fs::read(e.unwrap().path()).unwrap());
        }
        let has = |needle: &[u8]| bytes.windows(needle.len()).any(|w| w == needle);
        (has(b"small-marker-7f3a"), has(b"big-12345;"))
    };
    assert_eq!(on_disk(), (true, true), "the scan reads the data");
    s.delete_dataset_files(
        &d.id,
        SetAside {
            by: "key k",
            reason: "retention",
        },
    )
    .await
    .unwrap();
    assert_eq!(on_disk(), (false, false));
}

async fn datasets_excluded_with_their_results_then_bytes_deleted_under_a_tombstone(s: &dyn Store) {
    s.create_machine(&machine("M1")).await.unwrap();
    let upload = |at: &str, bytes: &[u8]| NewDataset {
        machine_id: "M1".into(),
        kind: "session".into(),
        measured_at: at.into(),
        samples: 3,
        files: vec![
            ("session.json".to_string(), b"{}".to_vec()),
            ("xy.csv".to_string(), bytes.to_vec()),
        ],
    };
    let d1 = s
        .insert_dataset(upload("2026-01-01T00:00:00Z", b"bad probe"))
        .await
        .unwrap();
    let d2 = s
        .insert_dataset(upload("2026-02-01T00:00:00Z", b"good"))
        .await
        .unwrap();
    let from = |d: &Dataset, at: &str, ec0y: f64| NewResult {
        check_model: None,
        dataset_id: Some(d.id.clone()),
        ..result("M1", at, ec0y)
    };
    let r1 = s
        .import_result(from(&d1, "2026-01-01T00:00:00Z", 1.0))
        .await
        .unwrap();
    let r1b = s
        .import_result(from(&d1, "2026-01-01T00:00:00Z", 1.5))
        .await
        .unwrap();
    let r2 = s
        .import_result(from(&d2, "2026-02-01T00:00:00Z", 2.0))
        .await
        .unwrap();
    // One of d1's results was excluded on its own before: it keeps its own record.
    let own = s
        .exclude_result(
            &r1b.id,
            SetAside {
                by: "key k0",
                reason: "typo",
            },
        )
        .await
        .unwrap()
        .excluded;

    // A job queued on d2: excluding or deleting it is refused naming the job, nothing
    // changes.
    let job = s
        .enqueue(NewJob {
            dataset_id: Some(d2.id.clone()),
            ..new_job("M1")
        })
        .await
        .unwrap();
    for refused in [
        s.exclude_dataset(
            &d2.id,
            SetAside {
                by: "key k1",
                reason: "r",
            },
        )
        .await,
        s.delete_dataset_files(
            &d2.id,
            SetAside {
                by: "key k1",
                reason: "r",
            },
        )
        .await,
    ] {
        match refused {
            Err(StoreError::Conflict(m)) => assert!(m.contains(&job.id), "{m}"),
            other => panic!("expected a conflict, got {other:?}"),
        }
    }
    let kept = s.get_dataset(&d2.id).await.unwrap();
    assert_eq!((kept.excluded, kept.deleted), (None, None));
    assert_eq!(s.dataset_file(&d2.id, "xy.csv").await.unwrap(), b"good");

    // Excluding d1: recorded, and its results excluded with the same record.
    let x = s
        .exclude_dataset(
            &d1.id,
            SetAside {
                by: "key k1",
                reason: "wrong probe",
            },
        )
        .await
        .unwrap();
    let rec = x.excluded.clone().unwrap();
    assert_eq!(
        (rec.by.as_str(), rec.reason.as_str()),
        ("key k1", "wrong probe")
    );
    assert_eq!(x.deleted, None);
    assert_eq!(
        s.get_result(&r1.id).await.unwrap().meta.excluded,
        Some(rec.clone())
    );
    assert_eq!(s.get_result(&r1b.id).await.unwrap().meta.excluded, own);
    let ids = |l: Vec<ResultMeta>| l.into_iter().map(|r| r.id).collect::<Vec<_>>();
    assert_eq!(
        ids(s.list_results("M1", "identification").await.unwrap()),
        std::slice::from_ref(&r2.id)
    );
    // Again: the first record is kept.
    let again = s
        .exclude_dataset(
            &d1.id,
            SetAside {
                by: "key k2",
                reason: "again",
            },
        )
        .await
        .unwrap();
    assert_eq!(again.excluded, Some(rec.clone()));
    // Listings: the excluded one only when asked for.
    let listed = |all| async move {
        s.list_datasets("M1", all)
            .await
            .unwrap()
            .into_iter()
            .map(|d| d.id)
            .collect::<Vec<_>>()
    };
    assert_eq!(listed(false).await, std::slice::from_ref(&d2.id));
    assert_eq!(listed(true).await, [d1.id.clone(), d2.id.clone()]);
    let all = s.list_datasets("M1", true).await.unwrap();
    assert_eq!(all[0].files.len(), 2);
    assert_eq!(all[0].excluded, Some(rec.clone()));
    // A result landing later from d1 (a job that got past the checks) lands excluded.
    let late = s
        .enqueue(NewJob {
            dataset_id: Some(d1.id.clone()),
            ..new_job("M1")
        })
        .await
        .unwrap();
    // The earlier job on d2 goes first in the queue: cancel it.
    s.cancel_job(&job.id).await.unwrap();
    let claimed = s.claim_job("w", 60_000).await.unwrap().unwrap();
    assert_eq!(claimed.id, late.id);
    let done = s
        .complete_job(
            Lease::new(&late.id, "w"),
            from(&d1, "2026-03-01T00:00:00Z", 3.0),
        )
        .await
        .unwrap();
    let landed = s.get_result(&done.result_id.unwrap()).await.unwrap();
    assert_eq!(landed.meta.excluded, Some(rec.clone()));
    assert_eq!(
        s.list_results("M1", "identification").await.unwrap().len(),
        1
    );
    // The same bytes as the excluded d1 may be uploaded again (a new dataset); those of
    // d2 may not.
    let d1_again = s
        .insert_dataset(upload("2026-01-01T00:00:00Z", b"bad probe"))
        .await
        .unwrap();
    assert_ne!(d1_again.id, d1.id);
    assert!(matches!(
        s.insert_dataset(upload("2026-02-01T00:00:00Z", b"good"))
            .await,
        Err(StoreError::Conflict(_))
    ));

    // Deleting d1's bytes: a tombstone (files named, sized and summed), the first
    // exclusion kept, the bytes gone.
    let t = s
        .delete_dataset_files(
            &d1.id,
            SetAside {
                by: "key admin",
                reason: "retention",
            },
        )
        .await
        .unwrap();
    let del = t.deleted.clone().unwrap();
    assert_eq!(
        (del.by.as_str(), del.reason.as_str()),
        ("key admin", "retention")
    );
    assert_eq!(t.excluded, Some(rec.clone()));
    assert_eq!(t.files, d1.files);
    assert_eq!(
        (t.sha256.as_str(), t.total_bytes),
        (d1.sha256.as_str(), d1.total_bytes)
    );
    for gone in [
        s.dataset_file(&d1.id, "xy.csv").await.map(|_| ()),
        s.dataset_files(&d1.id).await.map(|_| ()),
    ] {
        match gone {
            Err(StoreError::NotFound(m)) => assert!(m.contains("retention"), "{m}"),
            other => panic!("expected not found, got {other:?}"),
        }
    }
    let again = s
        .delete_dataset_files(
            &d1.id,
            SetAside {
                by: "key other",
                reason: "again",
            },
        )
        .await
        .unwrap();
    assert_eq!(again.deleted, Some(del));
    // The bytes are gone from the database, not only hidden.
    let counts = s.row_counts().await.unwrap();
    assert_eq!(counts.datasets, 3);

    // Deleting d2 (not excluded, its job cancelled): excluded and deleted with one
    // record, its result with it; d2's bytes are kept by the other datasets' files.
    let t2 = s
        .delete_dataset_files(
            &d2.id,
            SetAside {
                by: "key admin",
                reason: "wrong machine",
            },
        )
        .await
        .unwrap();
    assert_eq!(t2.excluded, t2.deleted);
    assert_eq!(
        s.get_result(&r2.id).await.unwrap().meta.excluded,
        t2.excluded
    );
    assert!(
        s.list_results("M1", "identification")
            .await
            .unwrap()
            .is_empty()
    );
    assert_eq!(
        s.dataset_file(&d1_again.id, "xy.csv").await.unwrap(),
        b"bad probe"
    );
    assert!(matches!(
        s.exclude_dataset(
            "ds_nope",
            SetAside {
                by: "k",
                reason: "r"
            }
        )
        .await,
        Err(StoreError::NotFound(_))
    ));
    assert!(matches!(
        s.delete_dataset_files(
            "ds_nope",
            SetAside {
                by: "k",
                reason: "r"
            }
        )
        .await,
        Err(StoreError::NotFound(_))
    ));
}
