//! A process's connections to PostgreSQL are capped by its pool size (`--db-pool`,
//! `MTCAL_DB_POOL`; docs/operations.md, "Operations"): 40 statements at once through a store
//! opened with a pool of 3 never hold more than 3 connections, as the server's own
//! `pg_stat_activity` counts them; the same load through a pool of 8 opens more than 3
//! (so the count can see a pool that is not capped). PostgreSQL only: a SQLite file's
//! connections are the process's own.

use mtcal_store::*;
use std::time::Duration;

/// Connections of the server whose `application_name` is `app`, counted by the server.
async fn connections(server: &str, app: &str) -> i64 {
    use sqlx::Connection;
    let mut c = sqlx::PgConnection::connect(server).await.unwrap();
    let n: i64 =
        sqlx::query_scalar("SELECT count(*) FROM pg_stat_activity WHERE application_name = $1")
            .bind(app)
            .fetch_one(&mut c)
            .await
            .unwrap();
    c.close().await.unwrap();
    n
}

/// The most connections the store opened with pool `size` held while 40 tasks ran 25
/// statements each, sampled every 20 ms and once after.
async fn most_connections(pg: &testing::ScratchPg, size: u32) -> i64 {
    let app = format!("pool_size_{size}_{}", pg.schema);
    let s = open_with(
        &format!("{}&application_name={app}", pg.url),
        StoreOptions {
            pool_size: Some(size),
            acquire_timeout: Duration::from_secs(30),
        },
    )
    .await
    .unwrap();
    let tasks: Vec<_> = (0..40)
        .map(|_| {
            let s = s.clone();
            tokio::spawn(async move {
                for _ in 0..25 {
                    s.row_counts().await.unwrap();
                }
            })
        })
        .collect();
    let mut most = 0;
    while tasks.iter().any(|t| !t.is_finished()) {
        most = most.max(connections(&pg.server, &app).await);
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    for t in tasks {
        t.await.unwrap();
    }
    // The pool keeps its connections open once made: the count after the load.
    most.max(connections(&pg.server, &app).await)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_pool_size_caps_a_process_connections() {
    let Some(pg) = testing::ScratchPg::create("the_pool_size_caps_a_process_connections")
        .await
        .unwrap()
    else {
        return;
    };
    let capped = most_connections(&pg, 3).await;
    assert!(
        (1..=3).contains(&capped),
        "pool of 3 held {capped} connections"
    );
    let wider = most_connections(&pg, 8).await;
    assert!(
        wider > 3,
        "pool of 8 held {wider} connections under the same load"
    );
    pg.drop_schema().await.unwrap();
}
