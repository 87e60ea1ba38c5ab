//! The limits of every route: body sizes, time limits, upload slots, and the connection
//! limits of the accept loop.

use std::time::Duration;

/// Body limit of every route but uploads, bytes.
pub const JSON_BODY_LIMIT: usize = 1 << 20;
/// Time limit of every route but uploads.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(30);
/// Longest an upload waits for a reading slot ([`MAX_CONCURRENT_UPLOADS`]) before its
/// own time limit ([`crate::state::Settings::upload_slot_time`]) starts; past it the
/// upload is refused with 408.
pub const UPLOAD_SLOT_WAIT: Duration = Duration::from_secs(300);
/// Uploads read at the same time by one process; more wait for a slot (at most
/// [`UPLOAD_SLOT_WAIT`]) before their body is read. An upload may decompress to the byte
/// limit (256 MiB) and its columns take about as much again, so two at a time bound a
/// process's upload memory near 1 GB whatever the number of clients.
pub const MAX_CONCURRENT_UPLOADS: usize = 2;

/// Time a client has to send a request's head (request line and headers) on an HTTP/1
/// connection, from the connection's start or the previous response: a connection that
/// trickles its head (a slow-loris client) is closed instead of holding a task forever.
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(10);
/// Time requests in flight have to finish once the server stops.
pub const SHUTDOWN_DRAIN: Duration = Duration::from_secs(30);
