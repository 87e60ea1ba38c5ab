//! The audit trail on both backends: events read back as recorded, newest first, by
//! every filter and page; and no statement rewrites them. An `UPDATE` or `DELETE` of a
//! row (and on PostgreSQL a `TRUNCATE`) sent straight to the database, as any holder of
//! the service's database role could send it, is refused by the table's triggers and
//! leaves the trail as it was. Runs on a SQLite file and, when `MTCAL_TEST_PG` names a
//! server, on PostgreSQL.

use mtcal_store::*;
use serde_json::json;

fn event(actor: &str, action: &str, machine: Option<&str>, n: i64) -> NewAuditEvent {
    NewAuditEvent {
        actor: actor.into(),
        actor_name: format!("{actor} label (mtk_{n:04})"),
        via: "api".into(),
        action: action.into(),
        target: format!("t{n}"),
        machine_id: machine.map(str::to_string),
        before: (n > 0).then(|| json!({"n": n - 1, "name": "Fräse 五"})),
        after: Some(json!({"n": n, "name": "Fräse 五"})),
        client: Some("192.0.2.7".into()),
    }
}

fn all() -> AuditQuery {
    AuditQuery {
        limit: 100,
        ..AuditQuery::default()
    }
}

/// Records four events and reads them back through every filter.
async fn recorded_and_read_back(s: &dyn Store) -> Vec<AuditEvent> {
    let sent = [
        event("key_a", "machine.create", Some("M1"), 0),
        event("key_b", "baseline.set", Some("M1"), 1),
        event("key_a", "key.create", None, 2),
        event("key_a", "machine.update", Some("M2"), 3),
    ];
    let mut kept = vec![];
    for e in &sent {
        let k = s.record_audit(e).await.unwrap();
        assert_eq!(&k.event, e, "read back as sent");
        kept.push(k);
    }
    assert!(
        kept.windows(2)
            .all(|w| w[0].seq < w[1].seq && w[0].at <= w[1].at)
    );
    let listed = s.list_audit(&all()).await.unwrap();
    let newest_first: Vec<_> = kept.iter().rev().cloned().collect();
    assert_eq!(listed, newest_first);
    let seqs = |q: AuditQuery| async move {
        let got = s.list_audit(&q).await.unwrap();
        got.iter()
            .map(|e| e.event.target.clone())
            .collect::<Vec<_>>()
    };
    let q = |f: fn(&mut AuditQuery)| {
        let mut q = all();
        f(&mut q);
        q
    };
    assert_eq!(
        seqs(q(|q| q.machine_id = Some("M1".into()))).await,
        ["t1", "t0"]
    );
    assert_eq!(
        seqs(q(|q| q.actor = Some("key_a".into()))).await,
        ["t3", "t2", "t0"]
    );
    let by_name = q(|q| q.actor = Some("key_b label (mtk_0001)".into()));
    assert_eq!(seqs(by_name).await, ["t1"]);
    assert_eq!(
        seqs(q(|q| q.action = Some("key.create".into()))).await,
        ["t2"]
    );
    let mut page = all();
    page.limit = 2;
    assert_eq!(seqs(page.clone()).await, ["t3", "t2"]);
    page.before = Some(kept[2].seq);
    assert_eq!(seqs(page).await, ["t1", "t0"]);
    let mut window = all();
    window.since = Some(kept[1].at.clone());
    window.until = Some("9999-01-01T00:00:00.000Z".into());
    assert!(seqs(window.clone()).await.contains(&"t1".to_string()));
    window.until = Some(kept[0].at.clone());
    assert!(
        seqs(window).await.is_empty(),
        "until is exclusive, since inclusive"
    );
    kept
}

/// Every rewrite sent straight to the database is refused, and the trail stays.
async fn rewrites_are_refused<DB: sqlx::Database>(
    s: &dyn Store,
    pool: &sqlx::Pool<DB>,
    statements: &[&str],
    kept: &[AuditEvent],
) where
    for<'c> &'c mut <DB as sqlx::Database>::Connection: sqlx::Executor<'c, Database = DB>,
{
    for sql in statements {
        let Err(e) = sqlx::raw_sql(sqlx::AssertSqlSafe(*sql)).execute(pool).await else {
            panic!("{sql}: accepted");
        };
        assert!(e.to_string().contains("append-only"), "{sql}: {e}");
    }
    let listed = s.list_audit(&all()).await.unwrap();
    assert_eq!(listed.len(), kept.len());
    assert_eq!(listed.last(), kept.first(), "the first event as recorded");
}

const REWRITES: [&str; 4] = [
    "UPDATE audit_events SET action = 'nothing' WHERE seq = (SELECT MIN(seq) FROM audit_events)",
    "UPDATE audit_events SET after_json = NULL",
    "DELETE FROM audit_events WHERE actor = 'key_b'",
    "DELETE FROM audit_events",
];

#[tokio::test]
async fn the_trail_reads_back_filtered_and_nothing_rewrites_it_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.sqlite");
    let s = open(path.to_str().unwrap()).await.unwrap();
    let kept = recorded_and_read_back(s.as_ref()).await;
    let pool = sqlx::SqlitePool::connect(&format!("sqlite://{}", path.display()))
        .await
        .unwrap();
    rewrites_are_refused(s.as_ref(), &pool, &REWRITES, &kept).await;
}

#[tokio::test]
async fn the_trail_reads_back_filtered_and_nothing_rewrites_it_on_postgres() {
    let test = "the_trail_reads_back_filtered_and_nothing_rewrites_it_on_postgres";
    let Some(pg) = testing::ScratchPg::create(test).await.unwrap() else {
        return;
    };
    let s = open(&pg.url).await.unwrap();
    let kept = recorded_and_read_back(s.as_ref()).await;
    let pool = sqlx::PgPool::connect(&pg.url).await.unwrap();
    let mut statements = REWRITES.to_vec();
    statements.push("TRUNCATE audit_events");
    rewrites_are_refused(s.as_ref(), &pool, &statements, &kept).await;
    pool.close().await;
    pg.drop_schema().await.unwrap();
}
