//! End-to-end tests of the service, one module per feature. Each test starts its own
//! service in this process on a fresh SQLite file ([`common::spawn_app`], port 0) and
//! drives it over HTTP with the typed client (`mtcal_client`); only the test that kills a
//! worker mid-job runs real `mtcal serve` processes ([`restart`]). Sessions come from
//! `mtcal demo --write-session` (known polynomial errors simulated by
//! `mtcal_solver::simulate`, full plan, noise σ = 0.1 µm).

mod common;

mod audit;
mod auth;
mod catch_up;
mod cli;
mod diagnose;
mod evaluation;
mod exclusion;
mod explained;
mod exports;
mod fleet;
mod history;
mod jobs;
mod restart;
mod roundtrip;
mod schemathesis;
mod security;
mod series;
mod slow_uploads;
mod uploads;
mod verification;
mod web;
