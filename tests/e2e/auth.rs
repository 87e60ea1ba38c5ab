//! Keys and scopes over a real connection (the order of 401/403 against other rejections
//! is tested in crates/server/tests/auth_first.rs).

use crate::common::*;
use reqwest::StatusCode;

#[tokio::test]
async fn keys_and_scopes_are_enforced_and_health_and_docs_are_open() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    let before = app.counts().await;
    let r = app
        .with_key("mtk_00000000000000000000000000000000")
        .machines(None, None)
        .await;
    assert_eq!(
        refused(r),
        (StatusCode::UNAUTHORIZED, "unauthorized".into())
    );
    let r = reqwest::get(format!("{}/api/v1/machines", app.url))
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    let weak = app.with_key(&app.read_key);
    assert!(weak.machines(None, None).await.is_ok());
    let r = weak.create_key(mtcal_store::Scope::Read, "x").await;
    assert_eq!(refused(r), (StatusCode::FORBIDDEN, "forbidden".into()));
    let r = app.client.create_key(mtcal_store::Scope::Read, "x").await;
    assert_eq!(refused(r), (StatusCode::FORBIDDEN, "forbidden".into()));
    assert_eq!(
        app.counts().await,
        before,
        "a refused request changed the database"
    );
    // An admin key creates keys; the new secret works at once.
    let created = app
        .with_key(&app.admin_key)
        .create_key(mtcal_store::Scope::Read, "new")
        .await
        .unwrap();
    assert!(
        app.with_key(&created.secret)
            .machines(None, None)
            .await
            .is_ok()
    );

    assert_eq!(app.client.health().await.unwrap().status, "ok");
    let r = reqwest::get(format!("{}/api-docs/openapi.json", app.url))
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK);
}
