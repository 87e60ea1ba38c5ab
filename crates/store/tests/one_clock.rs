//! The queue and the sign-in sessions keep time by the database's clock, not a host's:
//! this process plays hosts whose clocks are an hour ahead or behind
//! (`testing::skew_host_clock`), while the database's clock is right. A worker with a
//! fast clock must not keep a lease for an hour more, one with a slow clock must not
//! lose its lease at once, and a job queued by a fast host must be claimable at once.
//! Run on a SQLite file and, when `MTCAL_TEST_PG` names a server, on PostgreSQL. One
//! test, so that the skews never overlap.

use mtcal_store::testing::skew_host_clock;
use mtcal_store::*;
use std::time::Duration;

const HOUR_MS: i64 = 3_600_000;

fn job() -> NewJob {
    NewJob {
        kind: JobKind::Identify,
        machine_id: None,
        dataset_id: None,
        params: serde_json::json!({}),
        max_attempts: 3,
    }
}

async fn story(s: &dyn Store) {
    // Queued by a host an hour ahead: claimable now by a host with the right time.
    skew_host_clock(HOUR_MS);
    let queued = s.enqueue(job()).await.unwrap();
    skew_host_clock(0);
    let claimed = s.claim_job("right", 60_000).await.unwrap();
    assert_eq!(
        claimed.map(|j| j.id),
        Some(queued.id.clone()),
        "claimable at once"
    );

    // A worker an hour ahead claims with a 300 ms lease and dies: a reaper with the right
    // time reaps the job once the 300 ms are over, not an hour later.
    s.enqueue(job()).await.unwrap();
    skew_host_clock(HOUR_MS);
    let fast = s.claim_job("fast", 300).await.unwrap().expect("a job");
    skew_host_clock(0);
    assert_eq!(s.reap_expired().await.unwrap(), 0, "the lease still holds");
    tokio::time::sleep(Duration::from_millis(600)).await;
    assert_eq!(
        s.reap_expired().await.unwrap(),
        1,
        "the fast host's lease expired"
    );
    assert_eq!(s.get_job(&fast.id).await.unwrap().state, JobState::Queued);

    // A worker an hour behind claims with a minute's lease and is alive: a reaper with the
    // right time leaves it, and its heartbeats keep it.
    skew_host_clock(-HOUR_MS);
    let slow = s.claim_job("slow", 60_000).await.unwrap().expect("a job");
    skew_host_clock(0);
    assert_eq!(
        s.reap_expired().await.unwrap(),
        0,
        "the slow host's lease holds"
    );
    skew_host_clock(-HOUR_MS);
    let beat = s
        .heartbeat(
            Lease::new(&slow.id, "slow"),
            60_000,
            Progress {
                fraction: 0.5,
                message: "half",
            },
        )
        .await
        .unwrap();
    skew_host_clock(0);
    assert_eq!(beat, Heartbeat::Continue);
    assert_eq!(
        s.reap_expired().await.unwrap(),
        0,
        "renewed by the database's clock"
    );

    // A sign-in session started by a host an hour behind lasts its whole time.
    let (key, _) = s.create_key(Scope::Read, "clock").await.unwrap();
    skew_host_clock(-HOUR_MS);
    let session = s.create_session(&key.id, 60_000).await.unwrap();
    skew_host_clock(0);
    assert!(s.session(&session.token).await.unwrap().is_some());
}

#[tokio::test]
async fn leases_and_sessions_keep_the_databases_time() {
    let dir = tempfile::tempdir().unwrap();
    let sqlite = SqliteStore::open(dir.path().join("c.sqlite").to_str().unwrap())
        .await
        .unwrap();
    story(&sqlite).await;
    let Some(pg) = testing::ScratchPg::create("leases_and_sessions_keep_the_databases_time")
        .await
        .unwrap()
    else {
        return;
    };
    let s = PostgresStore::open(&pg.url).await.unwrap();
    story(&s).await;
    pg.drop_schema().await.unwrap();
}
