//! The statements of [`crate::Fleet`]: the fleet's drift rows and the fleet page.

use super::{Backend, Driver, dialect, qualified};
use crate::error::{Db as _, Result};
use crate::model::*;
use crate::rows::{self, Columns, FLEET_DRIFT_COLUMNS, MACHINE_COLUMNS};
use crate::{Fleet, StoreFuture};
use sqlx::Executor;
use std::collections::HashMap;

/// Stores a machine's fleet row unless the stored one was computed from a later read;
/// returns whether it was stored.
async fn upsert_fleet_drift<'e>(
    ex: impl Executor<'e, Database = Driver>,
    row: &FleetDriftRow,
) -> Result<bool> {
    let done = run!(
        execute(ex),
        "INSERT INTO fleet_drift (machine_id, read_at_ms, drift_um, drift_urad, entry, \
         latest_measured_at, basis) \
         VALUES ($1, $2, $3, $4, $5, $6, $7) ON CONFLICT (machine_id) DO UPDATE SET \
         read_at_ms = EXCLUDED.read_at_ms, drift_um = EXCLUDED.drift_um, \
         drift_urad = EXCLUDED.drift_urad, entry = EXCLUDED.entry, \
         latest_measured_at = EXCLUDED.latest_measured_at, basis = EXCLUDED.basis \
         WHERE fleet_drift.read_at_ms <= EXCLUDED.read_at_ms",
        &row.machine_id,
        row.read_at_ms,
        row.drift_um,
        row.drift_urad,
        row.entry.as_str(),
        &row.latest_measured_at,
        &row.basis
    )?;
    Ok(done.rows_affected() == 1)
}

/// The fleet page's filter on machines `m`, as SQL conditions with placeholders from `$1`
/// and their values: the asker's scope ([`scope_filter`]), the site; the tag matched
/// whole in the machine's JSON tag list.
fn fleet_filter(q: &FleetPageQuery) -> Result<(String, Vec<String>)> {
    let (scope, mut values) = scope_filter(q)?;
    let mut conditions = vec![scope];
    if let Some(site) = &q.site {
        values.push(site.clone());
        conditions.push(site_is(values.len(), site));
    }
    if let Some(tag) = &q.tag {
        conditions.push(tag_is(tag, &mut values)?);
    }
    Ok((conditions.join(" AND "), values))
}

/// The condition that machine `m`'s site is placeholder `$n`, whose value is `site` (a
/// machine without a site is in the site `default`).
fn site_is(n: usize, site: &str) -> String {
    if site == mtcal_api::keys::DEFAULT_SITE {
        format!("(m.site = ${n} OR m.site IS NULL)")
    } else {
        format!("m.site = ${n}")
    }
}

/// The condition that machine `m` has `tag` (the quoted tag in its JSON list, LIKE's
/// wildcards escaped), its value pushed onto `values`.
fn tag_is(tag: &str, values: &mut Vec<String>) -> Result<String> {
    let quoted = serde_json::to_string(tag).db()?;
    let escaped = quoted
        .replace('!', "!!")
        .replace('%', "!%")
        .replace('_', "!_");
    values.push(format!("%{escaped}%"));
    Ok(format!("m.tags LIKE ${} ESCAPE '!'", values.len()))
}

/// The asker's scope as conditions on machines `m` (from `$1`) and their values: one of
/// its sites, and one of its tags (`1 = 1`: the whole group).
fn scope_filter(q: &FleetPageQuery) -> Result<(String, Vec<String>)> {
    let (mut conditions, mut values) = (vec!["1 = 1".to_string()], Vec::new());
    if !q.within_sites.is_empty() {
        let mut any = Vec::new();
        for site in &q.within_sites {
            values.push(site.clone());
            any.push(site_is(values.len(), site));
        }
        conditions.push(format!("({})", any.join(" OR ")));
    }
    if !q.within_tags.is_empty() {
        let mut any = Vec::new();
        for tag in &q.within_tags {
            any.push(tag_is(tag, &mut values)?);
        }
        conditions.push(format!("({})", any.join(" OR ")));
    }
    Ok((conditions.join(" AND "), values))
}

/// The fleet order's key in `fleet_drift` and the index that holds it in the page's
/// order (largest first, ties by machine id); None for the order by machine id.
fn fleet_key(sort: FleetSort) -> Option<(&'static str, &'static str)> {
    match sort {
        FleetSort::DriftUm => Some(("drift_um", "fleet_drift_um")),
        FleetSort::DriftUrad => Some(("drift_urad", "fleet_drift_urad")),
        FleetSort::LastCheck => Some(("latest_measured_at", "fleet_drift_last_check")),
        FleetSort::Name => None,
    }
}

/// The fleet page's machines without an active alert that the filter keeps, in the
/// page's order, as statements that walk an index and stop after the page: with a key,
/// the machines that have it (key descending, ties by id), then `unkeyed`, those that
/// do not (no drift row yet, or an older row without the key), by id; without a key
/// (the order by id), every machine by id. The order is the one of
/// `ORDER BY f.key DESC NULLS LAST, m.id` over all of them.
struct FleetWalk {
    /// `FROM … WHERE …` of the walk.
    from: String,
    /// The walk's order.
    order: String,
    /// The machines without the key, ordered (`LIMIT` and `OFFSET` to add).
    unkeyed: Option<String>,
}

impl FleetWalk {
    const NOT_ALERTED: &str = "NOT EXISTS (SELECT 1 FROM alerts al \
         WHERE al.machine_id = m.id AND al.acknowledged_at IS NULL)";

    fn new(key: Option<(&str, &str)>, filter: &str) -> FleetWalk {
        let not_alerted = Self::NOT_ALERTED;
        match key {
            Some((k, index)) => FleetWalk {
                from: format!(
                    "FROM {} JOIN machines m ON m.id = f.machine_id \
                     WHERE f.{k} IS NOT NULL AND {filter} AND {not_alerted}",
                    dialect::walk("fleet_drift f", index)
                ),
                order: format!("f.{k} DESC, f.machine_id"),
                unkeyed: Some(format!(
                    "SELECT m.id AS id FROM machines m WHERE {filter} AND {not_alerted} \
                     AND NOT EXISTS (SELECT 1 FROM fleet_drift f \
                       WHERE f.machine_id = m.id AND f.{k} IS NOT NULL) \
                     ORDER BY m.id"
                )),
            },
            None => FleetWalk {
                from: format!("FROM machines m WHERE {filter} AND {not_alerted}"),
                order: "m.id".into(),
                unkeyed: None,
            },
        }
    }

    /// The ids of `limit` machines of the walk after the first `offset`.
    fn keyed(&self, limit: usize, offset: usize) -> String {
        let (from, order) = (&self.from, &self.order);
        let id = if self.unkeyed.is_some() {
            "f.machine_id"
        } else {
            "m.id"
        };
        format!("SELECT {id} AS id {from} ORDER BY {order} LIMIT {limit} OFFSET {offset}")
    }

    /// How many machines the walk holds (column `n`).
    fn count_keyed(&self) -> String {
        format!("SELECT COUNT(*) AS n {}", self.from)
    }
}

/// The distinct values of the machines' indexed column `column` (not NULL; columns `v`
/// and `col` = `name`), by a walk of its index that jumps from one value to the next: one
/// probe per value, not a read of every machine's entry.
fn distinct_machines(column: &str, name: &str) -> String {
    let d = format!("d_{name}");
    format!(
        "SELECT * FROM (WITH RECURSIVE {d}(v) AS (SELECT MIN({column}) FROM machines \
         UNION ALL SELECT (SELECT MIN({column}) FROM machines WHERE {column} > {d}.v) \
         FROM {d} WHERE {d}.v IS NOT NULL) \
         SELECT v, '{name}' AS col FROM {d} WHERE v IS NOT NULL) AS {d}_values"
    )
}

/// Statement `sql` with `values` bound to `$1`, `$2`, … in order.
fn bound(
    sql: String,
    values: &[String],
) -> sqlx::query::Query<'_, Driver, <Driver as sqlx::Database>::Arguments> {
    values
        .iter()
        .fold(sqlx::query(sqlx::AssertSqlSafe(sql)), |q, v| q.bind(v))
}

/// The `id` column of the rows `sql` selects with `values` bound.
async fn ids<'e>(
    sql: String,
    values: &[String],
    ex: impl Executor<'e, Database = Driver>,
) -> Result<Vec<String>> {
    bound(sql, values)
        .fetch_all(ex)
        .await
        .db()?
        .iter()
        .map(|r| r.text("id"))
        .collect()
}

/// A connection of the backend, inside the fleet page's read snapshot.
type Conn = <Driver as sqlx::Database>::Connection;

/// The page's machines in order, with their active alerts: the machines with active
/// alerts first, then the others, walked in the order of an index.
async fn page_machines(
    q: &FleetPageQuery,
    filter: &str,
    binds: &[String],
    conn: &mut Conn,
) -> Result<Vec<(String, i64)>> {
    let key = fleet_key(q.sort);
    let offset = usize::try_from(q.offset).unwrap_or(0);
    let limit = usize::try_from(q.limit).unwrap_or(0);
    // 1. The machines with active alerts (few: alerts are acknowledged), all of
    //    those the filter keeps, in the page's order: they come first.
    let order = match key {
        Some((k, _)) => format!("f.{k} DESC NULLS LAST, m.id"),
        None => "m.id".into(),
    };
    let alerted = bound(
        format!(
            "SELECT m.id AS id, a.n AS n FROM (SELECT machine_id, COUNT(*) AS n \
             FROM alerts WHERE acknowledged_at IS NULL GROUP BY machine_id) a \
             JOIN machines m ON m.id = a.machine_id \
             LEFT JOIN fleet_drift f ON f.machine_id = m.id \
             WHERE {filter} ORDER BY {order}"
        ),
        binds,
    )
    .fetch_all(&mut *conn)
    .await
    .db()?
    .iter()
    .map(|r| Ok((r.text("id")?, r.int("n")?)))
    .collect::<Result<Vec<_>>>()?;
    let mut page: Vec<(String, i64)> = alerted.iter().skip(offset).take(limit).cloned().collect();
    // 2. The others, walked in the order of an index and stopped once the page
    //    is full (no sort of the whole fleet): those with the sort key, then
    //    (sorts by a key some machines lack) those without it, by id.
    let skip = offset.saturating_sub(alerted.len());
    let need = limit - page.len();
    if need > 0 {
        let walk = FleetWalk::new(key, filter);
        let keyed = ids(walk.keyed(need, skip), binds, &mut *conn).await?;
        let got = keyed.len();
        page.extend(keyed.into_iter().map(|id| (id, 0)));
        if let Some(unkeyed) = &walk.unkeyed
            && got < need
        {
            // The walk ran out: it held `skip + got` machines unless it started
            // past its end.
            let walked = if got == 0 && skip > 0 {
                let n: i64 = bound(walk.count_keyed(), binds)
                    .fetch_one(&mut *conn)
                    .await
                    .db()?
                    .int("n")?;
                usize::try_from(n).unwrap_or(0)
            } else {
                skip + got
            };
            let sql = format!(
                "{unkeyed} LIMIT {} OFFSET {}",
                need - got,
                skip.saturating_sub(walked)
            );
            page.extend(
                ids(sql, binds, &mut *conn)
                    .await?
                    .into_iter()
                    .map(|id| (id, 0)),
            );
        }
    }
    Ok(page)
}

/// The machines and the drift rows of the machines `page_ids`, by id.
async fn page_records(
    page_ids: &[String],
    conn: &mut Conn,
) -> Result<(HashMap<String, Machine>, HashMap<String, FleetDriftRow>)> {
    let list = (1..=page_ids.len())
        .map(|i| format!("${i}"))
        .collect::<Vec<_>>()
        .join(", ");
    let (mut machines, mut drifts) = (HashMap::new(), HashMap::new());
    if !page_ids.is_empty() {
        let sql = format!("SELECT {MACHINE_COLUMNS} FROM machines WHERE id IN ({list})");
        for r in bound(sql, page_ids).fetch_all(&mut *conn).await.db()? {
            let m = rows::machine(&r)?;
            machines.insert(m.id.clone(), m);
        }
        let sql =
            format!("SELECT {FLEET_DRIFT_COLUMNS} FROM fleet_drift WHERE machine_id IN ({list})");
        for r in bound(sql, page_ids).fetch_all(&mut *conn).await.db()? {
            let d = rows::fleet_drift(&r)?;
            drifts.insert(d.machine_id.clone(), d);
        }
    }
    Ok((machines, drifts))
}

/// 4. For the machines without a drift row (no identification), `lacking`: each one's
///    latest result of another kind, one index seek each, in one statement.
async fn other_checks(lacking: &[String], conn: &mut Conn) -> Result<HashMap<String, LastCheck>> {
    let mut others = HashMap::new();
    if !lacking.is_empty() {
        let sql = (1..=lacking.len())
            .map(|i| {
                format!(
                    "SELECT * FROM (SELECT id, machine_id, kind, measured_at FROM results \
                     WHERE machine_id = ${i} AND excluded_at IS NULL \
                     ORDER BY measured_at DESC, created_at DESC, id DESC LIMIT 1) AS r{i}"
                )
            })
            .collect::<Vec<_>>()
            .join(" UNION ALL ");
        for r in bound(sql, lacking).fetch_all(&mut *conn).await.db()? {
            others.insert(
                r.text("machine_id")?,
                LastCheck {
                    result_id: r.text("id")?,
                    kind: r.text("kind")?,
                    measured_at: r.text("measured_at")?,
                },
            );
        }
    }
    Ok(others)
}

/// The filters' choices: every site, and every machine's tag list as stored (JSON); for
/// an asker limited to sites or tags, those of the machines in its scope only.
async fn choices(q: &FleetPageQuery, conn: &mut Conn) -> Result<(Vec<String>, Vec<String>)> {
    let (mut sites, mut tag_lists) = (Vec::new(), Vec::new());
    let (scope, values) = scope_filter(q)?;
    let sql = if values.is_empty() {
        format!(
            "{} UNION ALL {}",
            distinct_machines("site", "site"),
            distinct_machines("tags", "tags")
        )
    } else {
        format!(
            "SELECT DISTINCT COALESCE(m.site, '{}') AS v, 'site' AS col FROM machines m \
             WHERE {scope} UNION ALL \
             SELECT DISTINCT m.tags AS v, 'tags' AS col FROM machines m WHERE {scope}",
            mtcal_api::keys::DEFAULT_SITE
        )
    };
    for r in bound(sql, &values).fetch_all(&mut *conn).await.db()? {
        match r.text("col")?.as_str() {
            "site" => sites.push(r.text("v")?),
            _ => tag_lists.push(r.text("v")?),
        }
    }
    Ok((sites, tag_lists))
}

/// The page's rows in order, inside one read snapshot `conn`.
async fn page_rows(q: &FleetPageQuery, conn: &mut Conn) -> Result<Vec<FleetPageRow>> {
    let (filter, binds) = fleet_filter(q)?;
    let page = page_machines(q, &filter, &binds, conn).await?;
    // 3. Only the page's rows are read whole (a machine's entry is kilobytes), by id
    //    from each table (a join would let a planner scan the drift rows).
    let page_ids: Vec<String> = page.iter().map(|(id, _)| id.clone()).collect();
    let (mut machines, mut drifts) = page_records(&page_ids, conn).await?;
    let lacking: Vec<String> = page_ids
        .iter()
        .filter(|id| !drifts.contains_key(*id))
        .cloned()
        .collect();
    let mut others = other_checks(&lacking, conn).await?;
    Ok(page
        .into_iter()
        .filter_map(|(id, active_alerts)| {
            Some(FleetPageRow {
                drift: drifts.remove(&id),
                other_check: others.remove(&id),
                machine: machines.remove(&id)?,
                active_alerts,
            })
        })
        .collect())
}

/// How many machines the filter keeps, and the filters' choices (sorted, tags from
/// every machine's list).
async fn counts(q: &FleetPageQuery, conn: &mut Conn) -> Result<FleetCounts> {
    let (filter, binds) = fleet_filter(q)?;
    let total = bound(
        format!("SELECT COUNT(*) AS n FROM machines m WHERE {filter}"),
        &binds,
    )
    .fetch_one(&mut *conn)
    .await
    .db()?
    .int("n")?;
    let (mut sites, tag_lists) = choices(q, conn).await?;
    sites.sort();
    let mut tags = Vec::new();
    for t in &tag_lists {
        tags.extend(serde_json::from_str::<Vec<String>>(t).db()?);
    }
    tags.sort();
    tags.dedup();
    Ok(FleetCounts { total, sites, tags })
}

impl Fleet for Backend {
    fn put_fleet_drift<'a>(&'a self, row: &'a FleetDriftRow) -> StoreFuture<'a, bool> {
        Box::pin(async move { upsert_fleet_drift(&self.pool, row).await })
    }

    fn put_fleet_drifts<'a>(&'a self, rows: &'a [FleetDriftRow]) -> StoreFuture<'a, usize> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let mut stored = 0;
            for row in rows {
                stored += usize::from(upsert_fleet_drift(&mut *tx, row).await?);
            }
            tx.commit().await.db()?;
            Ok(stored)
        })
    }

    fn fleet_drift_bases<'a>(
        &'a self,
        after: Option<&'a str>,
        through: Option<&'a str>,
    ) -> StoreFuture<'a, Vec<(String, Option<String>)>> {
        Box::pin(async move {
            let upto = if through.is_some() {
                "AND machine_id <= $2"
            } else {
                "AND $2 IS NULL"
            };
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(format!(
                    "SELECT machine_id, basis FROM fleet_drift WHERE machine_id > $1 {upto} \
                     ORDER BY machine_id"
                )),
                after.unwrap_or(""),
                through
            )?
            .iter()
            .map(|r| Ok((r.text("machine_id")?, r.opt_text("basis")?)))
            .collect()
        })
    }

    fn delete_fleet_drift<'a>(
        &'a self,
        machine_id: &'a str,
        read_at_ms: i64,
    ) -> StoreFuture<'a, bool> {
        Box::pin(async move {
            let done = run!(
                execute(&self.pool),
                "DELETE FROM fleet_drift WHERE machine_id = $1 AND read_at_ms < $2",
                machine_id,
                read_at_ms
            )?;
            Ok(done.rows_affected() == 1)
        })
    }

    fn fleet_drift_ranked(
        &self,
        by_um: bool,
        limit: usize,
    ) -> StoreFuture<'_, Vec<(FleetDriftRow, String, Option<String>)>> {
        Box::pin(async move {
            let order = if by_um { "drift_um" } else { "drift_urad" };
            let q = format!(
                "SELECT {}, m.name, m.site \
                 FROM fleet_drift f JOIN machines m ON m.id = f.machine_id \
                 ORDER BY f.{order} DESC, f.machine_id LIMIT $1",
                qualified("f", FLEET_DRIFT_COLUMNS)
            );
            let rows = run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                i64::try_from(limit).unwrap_or(i64::MAX)
            )?;
            rows.iter()
                .map(|r| Ok((rows::fleet_drift(r)?, r.text("name")?, r.opt_text("site")?)))
                .collect()
        })
    }

    fn fleet_page<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetPage> {
        Box::pin(async move {
            // One read snapshot: an alert raised or acknowledged between the statements
            // must not show a machine twice or leave it out.
            let mut tx = self.read_snapshot().await?;
            let rows = page_rows(q, &mut tx).await?;
            let c = counts(q, &mut tx).await?;
            tx.commit().await.db()?;
            Ok(FleetPage {
                rows,
                total: c.total,
                sites: c.sites,
                tags: c.tags,
            })
        })
    }

    fn fleet_page_rows<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, Vec<FleetPageRow>> {
        Box::pin(async move {
            let mut tx = self.read_snapshot().await?;
            let rows = page_rows(q, &mut tx).await?;
            tx.commit().await.db()?;
            Ok(rows)
        })
    }

    fn fleet_counts<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetCounts> {
        Box::pin(async move {
            let mut tx = self.read_snapshot().await?;
            let c = counts(q, &mut tx).await?;
            tx.commit().await.db()?;
            Ok(c)
        })
    }
}
