//! Sites and roles in the store, on both backends: a key keeps the sites and tags it was
//! created with (a key of the whole group has none), the last admin key of the whole
//! group cannot be revoked while a site's admin key can, and the fleet page limited to a
//! scope shows, counts and offers as choices the machines of that scope only (a machine
//! without a site is in the site `default`). Runs on SQLite and, when `MTCAL_TEST_PG`
//! names a server, on PostgreSQL.

use mtcal_store::*;
use serde_json::json;

fn machine(id: &str, site: Option<&str>, tags: &[&str]) -> Machine {
    Machine {
        id: id.into(),
        name: format!("Machine {id}"),
        topology: json!({"workpiece": ["X", "Y"], "tool": ["Z"]}),
        travel_mm: Default::default(),
        site: site.map(Into::into),
        tags: tags.iter().map(|t| t.to_string()).collect(),
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

async fn keys_keep_their_scope(s: &dyn Store) {
    let (group, _) = s.create_key(Scope::Admin, "group").await.unwrap();
    assert!(group.is_group() && group.sites.is_empty() && group.tags.is_empty());
    let (north, secret) = s
        .create_key_in(
            Scope::Admin,
            "north",
            &strings(&["Nord 北"]),
            &strings(&["5-axis"]),
        )
        .await
        .unwrap();
    let read = s.key_by_secret(&secret).await.unwrap().expect("key");
    assert_eq!(read.sites, ["Nord 北"]);
    assert_eq!(read.tags, ["5-axis"]);
    assert_eq!(read, north);
    // Both keys may carry the same millisecond: compared as a set (by id).
    let mut listed = s.list_keys().await.unwrap();
    listed.sort_by(|a, b| a.id.cmp(&b.id));
    let mut want = [group.clone(), north.clone()];
    want.sort_by(|a, b| a.id.cmp(&b.id));
    assert_eq!(listed, want);
    // Refused before anything is stored: a blank site, a site twice, a control char.
    for bad in [vec![" "], vec!["a", "a"], vec!["a\u{7}"]] {
        let e = s
            .create_key_in(Scope::Read, "bad", &strings(&bad), &[])
            .await
            .expect_err("refused");
        assert!(matches!(e, StoreError::Invalid(_)), "{e:?}");
    }
    assert_eq!(s.list_keys().await.unwrap().len(), 2);
    // A site's admin key is no admin of the whole group: the group's last one stays.
    let e = s
        .revoke_key(&group.id)
        .await
        .expect_err("the last group admin");
    assert!(matches!(e, StoreError::Conflict(_)), "{e:?}");
    let revoked = s.revoke_key(&north.id).await.unwrap();
    assert!(revoked.revoked_at.is_some());
    assert!(s.key_by_secret(&secret).await.unwrap().is_none());
}

async fn the_fleet_page_keeps_to_a_scope(s: &dyn Store) {
    for m in [
        machine("A1", Some("north"), &["vmc"]),
        machine("A2", Some("north"), &["lathe"]),
        machine("B1", Some("south"), &["vmc", "south-only"]),
        machine("C1", None, &["old"]),
    ] {
        s.create_machine(&m).await.unwrap();
    }
    let page = |sites: &[&str], tags: &[&str], site: Option<&str>| FleetPageQuery {
        site: site.map(Into::into),
        tag: None,
        sort: FleetSort::Name,
        offset: 0,
        limit: 10,
        within_sites: strings(sites),
        within_tags: strings(tags),
    };
    let shown =
        |p: &FleetPage| -> Vec<String> { p.rows.iter().map(|r| r.machine.id.clone()).collect() };
    let all = s.fleet_page(&page(&[], &[], None)).await.unwrap();
    assert_eq!(shown(&all), ["A1", "A2", "B1", "C1"]);
    assert_eq!(all.sites, ["north", "south"], "the group's choices");
    let north = s.fleet_page(&page(&["north"], &[], None)).await.unwrap();
    assert_eq!(shown(&north), ["A1", "A2"]);
    assert_eq!(north.total, 2);
    assert_eq!(north.sites, ["north"]);
    assert_eq!(north.tags, ["lathe", "vmc"], "no tag of another site");
    // A filter outside the scope finds nothing, whatever exists there.
    let across = s
        .fleet_page(&page(&["north"], &[], Some("south")))
        .await
        .unwrap();
    assert!(across.rows.is_empty() && across.total == 0);
    let vmc = s
        .fleet_page(&page(&["north"], &["vmc"], None))
        .await
        .unwrap();
    assert_eq!(shown(&vmc), ["A1"]);
    // A machine without a site is in the site `default`.
    let default = s.fleet_page(&page(&["default"], &[], None)).await.unwrap();
    assert_eq!(shown(&default), ["C1"]);
    assert_eq!(default.sites, ["default"]);
    let both = s
        .fleet_page(&page(&["default", "south"], &[], None))
        .await
        .unwrap();
    assert_eq!(shown(&both), ["B1", "C1"]);
}

#[tokio::test]
async fn sites_and_roles_on_sqlite() {
    let s = open("sqlite::memory:").await.unwrap();
    keys_keep_their_scope(s.as_ref()).await;
    the_fleet_page_keeps_to_a_scope(s.as_ref()).await;
}

#[tokio::test]
async fn sites_and_roles_on_postgres() {
    let Some(pg) = testing::ScratchPg::create("sites_and_roles_on_postgres")
        .await
        .unwrap()
    else {
        return;
    };
    let s = open(&pg.url).await.unwrap();
    keys_keep_their_scope(s.as_ref()).await;
    the_fleet_page_keeps_to_a_scope(s.as_ref()).await;
    pg.drop_schema().await.unwrap();
}
