//! The server's tests, one binary: a module per file beside this one (one link, not one
//! per file), and the in-process app they share. `upload_slots` is a binary of its own:
//! it reads a gauge that counts the whole process.

mod common;

mod accepted;
mod auth_first;
mod baseline;
mod contract;
mod fleet_rows;
mod fleet_total;
mod openapi;
mod operations;
mod outage;
mod parity;
mod rejections;
mod sites;
mod tolerances_alerts;
mod tolerant;
