//! The statements of [`crate::Machines`].

use super::{Backend, row_by_id};
use crate::error::{Db as _, Result, unique_conflict};
use crate::model::*;
use crate::rows::{self, MACHINE_COLUMNS};
use crate::rules::{self, MachineJson};
use crate::{Machines, StoreFuture, now_rfc3339};

impl Backend {
    async fn machine(&self, id: &str) -> Result<Machine> {
        let q = format!("SELECT {MACHINE_COLUMNS} FROM machines WHERE id = $1");
        let row = row_by_id(&self.pool, q, id, "machine").await?;
        rows::machine(&row)
    }
}

impl Machines for Backend {
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine> {
        Box::pin(async move {
            crate::text::check_machine(m)?;
            let now = now_rfc3339();
            let json = MachineJson::of(m)?;
            bound!("INSERT INTO machines (id, name, topology, travel_mm, site, tags, \
                 baseline_result_id, created_at, updated_at) VALUES ($1, $2, $3, $4, $5, $6, NULL, $7, $7)", &m.id, &m.name, &json.topology, &json.travel_mm, &m.site, &json.tags, &now)
            .execute(&self.pool)
            .await
            .map_err(|e| unique_conflict(e, || format!("machine {} already exists", m.id)))?;
            self.machine(&m.id).await
        })
    }

    fn get_machine<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Machine> {
        Box::pin(self.machine(id))
    }

    fn update_machine<'a>(&'a self, id: &'a str, p: &'a MachinePatch) -> StoreFuture<'a, Machine> {
        Box::pin(async move {
            let mut m = self.machine(id).await?;
            let baseline = match &p.baseline_result_id {
                Some(b) => Some(self.result_meta(b).await?),
                None => None,
            };
            rules::apply_patch(&mut m, p, baseline.as_ref())?;
            crate::text::check_machine(&m)?;
            let json = MachineJson::of(&m)?;
            run!(
                execute(&self.pool),
                "UPDATE machines SET name = $2, topology = $3, travel_mm = $4, site = $5, tags = $6, \
                 baseline_result_id = $7, updated_at = $8 WHERE id = $1",
                id,
                &m.name,
                &json.topology,
                &json.travel_mm,
                &m.site,
                &json.tags,
                &m.baseline_result_id,
                now_rfc3339()
            )?;
            self.machine(id).await
        })
    }

    fn list_machines<'a>(
        &'a self,
        after: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Machine>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {MACHINE_COLUMNS} FROM machines WHERE id > $1 ORDER BY id LIMIT $2"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                after.unwrap_or(""),
                limit
            )?
            .iter()
            .map(rows::machine)
            .collect()
        })
    }
}
