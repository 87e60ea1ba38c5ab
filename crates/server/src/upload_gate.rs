//! What every route that takes an upload passes (the API's dataset upload and the
//! dashboard's upload form alike), so that one set of limits covers them all:
//!
//! * **Slots**: at most [`crate::MAX_CONCURRENT_UPLOADS`] uploads are read at once per
//!   process, counted over both routes (one semaphore, [`Gate`]); the others wait for a
//!   slot (at most [`crate::UPLOAD_SLOT_WAIT`]).
//! * **Minimum rate**: once an upload has its slot, after a grace period
//!   ([`crate::Settings::upload_grace`], 10 s by default) its body must have arrived at
//!   an average of at least [`crate::Settings::min_upload_rate`] bytes per second
//!   (16 KiB/s by default) since reading began; a client slower than that is answered
//!   408 `timeout` naming the rate, and its slot goes to the next upload. Two clients
//!   sending a byte a second no longer hold both slots for minutes.
//! * **Slot time**: an upload holds its slot at most [`crate::Settings::upload_slot_time`]
//!   (`--upload-slot-seconds`, 120 s by default), from taking it to its answer: reading,
//!   checking and storing. Past it the upload is answered 408 `timeout` naming the limit,
//!   nothing is stored, and the slot goes to the next upload. A client just above the
//!   minimum rate cannot hold a slot for longer than that either.
//! * **Size**: the route's body limit (`--max-upload-bytes`, also on the decompressed
//!   size).

use crate::error::ApiError;
use axum::Router;
use axum::body::{Body, Bytes};
use axum::extract::{Request, State};
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use hyper::body::{Frame, SizeHint};
use std::pin::Pin;
use std::sync::Arc;
use std::sync::Mutex;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::time::{Instant, Sleep};

/// The upload slots of one process, shared by every upload route.
#[derive(Clone)]
pub struct Gate {
    pub slots: Arc<tokio::sync::Semaphore>,
}

impl Gate {
    pub fn new() -> Gate {
        Gate {
            slots: Arc::new(tokio::sync::Semaphore::new(crate::MAX_CONCURRENT_UPLOADS)),
        }
    }

    /// The layer that takes a slot before the upload is read.
    pub fn layer(&self) -> tower::limit::GlobalConcurrencyLimitLayer {
        tower::limit::GlobalConcurrencyLimitLayer::with_semaphore(self.slots.clone())
    }
}

impl Default for Gate {
    fn default() -> Self {
        Gate::new()
    }
}

/// Puts `routes` (routes that take an upload) behind the process's upload gate: a slot of
/// [`Gate`] (shared by every upload route), counted in `mtcal_uploads_reading` while it
/// is held, the minimum rate and the slot time ([`slot_limits`]) from the moment the slot
/// is taken. The route's own body limit sits inside (the caller's layers). The caller
/// bounds the whole, wait included, with [`outer_limit`].
pub fn guard<S: Clone + Send + Sync + 'static>(
    routes: Router<S>,
    app: &crate::AppState,
) -> Router<S> {
    routes
        // The upload's own time limit starts when it has a reading slot: waiting behind
        // other uploads does not use it up. The wait is bounded by an outer limit.
        .layer(axum::middleware::from_fn_with_state(
            app.clone(),
            slot_limits,
        ))
        .layer(axum::middleware::from_fn(crate::metrics::reading_upload))
        .layer(app.uploads.layer())
}

/// The time limit of an upload route as a whole: the wait for a slot
/// ([`crate::UPLOAD_SLOT_WAIT`]) and the slot's own time.
pub fn outer_limit(app: &crate::AppState) -> tower_http::timeout::TimeoutLayer {
    tower_http::timeout::TimeoutLayer::with_status_code(
        StatusCode::REQUEST_TIMEOUT,
        crate::UPLOAD_SLOT_WAIT + app.settings.upload_slot_time,
    )
}

/// The minimum rate an upload's body must keep (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub struct MinRate {
    pub bytes_per_second: u64,
    pub grace: Duration,
}

impl MinRate {
    /// The refusal of an upload that fell below this rate.
    fn refusal(&self, received: u64, elapsed: Duration) -> ApiError {
        ApiError::Timeout(format!(
            "the upload was slower than the minimum rate of {} bytes/s (after a grace period \
             of {} s): {received} bytes in {:.1} s",
            self.bytes_per_second,
            self.grace.as_secs(),
            elapsed.as_secs_f64()
        ))
    }
}

/// A request body that fails once it falls below a [`MinRate`] (and leaves the refusal
/// in `tripped`).
struct RateBody {
    inner: Body,
    rate: MinRate,
    start: Instant,
    received: u64,
    deadline: Pin<Box<Sleep>>,
    /// The refusal's message, once it fell below the rate.
    tripped: Arc<Mutex<Option<String>>>,
}

impl RateBody {
    /// When the body falls below the rate unless more arrives: the grace period's end, or
    /// the time at which `received` bytes make exactly the minimum average.
    fn next_deadline(&self) -> Instant {
        let rate = self.rate.bytes_per_second.max(1);
        let earned = Duration::from_secs_f64(self.received as f64 / rate as f64);
        self.start + self.rate.grace.max(earned)
    }
}

impl hyper::body::Body for RateBody {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        match Pin::new(&mut self.inner).poll_frame(cx) {
            Poll::Ready(Some(Ok(frame))) => {
                if let Some(d) = frame.data_ref() {
                    self.received += d.len() as u64;
                    let next = self.next_deadline();
                    self.deadline.as_mut().reset(next);
                }
                Poll::Ready(Some(Ok(frame)))
            }
            Poll::Ready(other) => Poll::Ready(other),
            Poll::Pending => match self.deadline.as_mut().poll(cx) {
                Poll::Ready(()) => {
                    let e = self
                        .rate
                        .refusal(self.received, self.start.elapsed())
                        .to_string();
                    if let Ok(mut t) = self.tripped.lock() {
                        *t = Some(e.clone());
                    }
                    Poll::Ready(Some(Err(axum::Error::new(e))))
                }
                Poll::Pending => Poll::Pending,
            },
        }
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

/// Middleware inside an upload route's slot (it starts when reading can start): reads the
/// body at the minimum rate of the service's settings and answers within the slot time;
/// an upload that falls below the rate, or holds the slot longer, is answered 408
/// `timeout` naming the limit it broke, and the connection is closed.
pub async fn slot_limits(State(s): State<crate::AppState>, req: Request, next: Next) -> Response {
    let rate = MinRate {
        bytes_per_second: s.settings.min_upload_rate,
        grace: s.settings.upload_grace,
    };
    let slot_time = s.settings.upload_slot_time;
    let tripped = Arc::new(Mutex::new(None));
    let req = if rate.bytes_per_second == 0 {
        req
    } else {
        let (parts, body) = req.into_parts();
        let start = Instant::now();
        let body = RateBody {
            inner: body,
            rate,
            start,
            received: 0,
            deadline: Box::pin(tokio::time::sleep_until(start + rate.grace)),
            tripped: tripped.clone(),
        };
        Request::from_parts(parts, Body::new(body))
    };
    let message = match tokio::time::timeout(slot_time, next.run(req)).await {
        Err(_) => format!(
            "the upload held its reading slot longer than the limit of {} s \
             (reading, checking and storing it); send it faster or split it",
            slot_time.as_secs_f64()
        ),
        Ok(resp) => match tripped.lock().ok().and_then(|mut t| t.take()) {
            Some(message) => message,
            None => return resp,
        },
    };
    tracing::warn!(%message, "an upload broke a time limit of its slot and was refused");
    let mut refused = ApiError::Timeout(message).into_response();
    // The rest of the body is not read: the connection ends with the answer.
    refused.headers_mut().insert(
        axum::http::header::CONNECTION,
        axum::http::HeaderValue::from_static("close"),
    );
    refused
}
