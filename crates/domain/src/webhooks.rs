//! Webhook delivery: the URL rules of a webhook target, where a target may lead
//! ([`TargetPolicy`]), the targets of a machine (the webhooks of its tags' profiles),
//! and the POST with its tries and limits.
//!
//! **Where a webhook may go.** A target's host is resolved and refused when any of its
//! addresses is loopback, private, link-local, shared (carrier-grade NAT), multicast,
//! broadcast, unspecified, reserved or documentation space ([`reserved`]: the IANA
//! special-purpose registries; IPv6 forms that carry an IPv4 address, IPv4-mapped,
//! NAT64 and 6to4, as that address; IPv4-compatible, Teredo, NAT64 local-use and
//! site-local refused whole), unless the operator's allow-list ([`TargetPolicy::allow`],
//! `MTCAL_WEBHOOK_ALLOW`) names the host or a network holding the address. The
//! service's own ports and its database's are refused even to an allowed host
//! ([`TargetPolicy::own`]). Numeric host forms (`2130706433`, `0x7f.1`) are read as the
//! addresses they are (WHATWG URL parsing). No credentials in the URL
//! (`user:password@`), and no control character or blank anywhere in it (URL parsers
//! drop tabs and line feeds silently, so the stored text would not be the URL used). The check runs when a
//! profile is saved and again at every delivery, whose connection goes to the very
//! addresses just checked (no second DNS answer can point it elsewhere).
//!
//! **Signature.** Every delivery of a webhook with a secret carries the header
//! [`SIGNATURE_HEADER`] `t=<unix seconds>,v1=<hex>`: HMAC-SHA256, keyed with the
//! webhook's secret, of the timestamp, a full stop and the body's bytes
//! (`<t>.<body>`, the scheme of Stripe's webhooks; [`signature`]). The receiver
//! recomputes it, compares in constant time and refuses old timestamps (replays);
//! docs/api.md shows how. The secret is set or generated when the profile is written
//! and never shown again, logged or put in a URL.
//!
//! **Outbox.** A delivery is a row of the database ([`mtcal_store::WebhookDelivery`]),
//! written in the transaction that stores its alert, and tried by the workers
//! ([`deliver_next`]): each try within [`WEBHOOK_TIMEOUT`], redirects not followed, no
//! proxy; a failed try is tried again after [`Retries::first`], doubling up to
//! [`Retries::max`], until [`Retries::attempts`] tries are spent (`failed`); a 2xx
//! answer is `delivered`; a refused target fails at once. A claimed try moves the
//! delivery's next time [`Retries::lease`] ahead, so that a try whose worker died is made
//! again by another (or the restarted) worker: a receiver may see a delivery twice and
//! should treat the alert's `id` as the key. Times are the database's clock. Failures
//! are logged with the URL without query ([`shown`]); they never fail what raised the
//! alert.

use crate::error::DomainError;
use hmac::{Hmac, Mac};
use ipnet::IpNet;
use serde::{Deserialize, Serialize};
use sha2::Sha256;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
use std::time::Duration;

/// Time limit of one try (connect, send, answer), and of resolving a target's host.
pub const WEBHOOK_TIMEOUT: Duration = Duration::from_secs(5);

/// How the outbox tries a delivery (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Retries {
    /// Tries per delivery.
    pub attempts: u32,
    /// Wait after the first failed try; doubled after each further one.
    pub first: Duration,
    /// Longest wait between two tries.
    pub max: Duration,
    /// How long a claimed try holds its delivery (longer than a try can take).
    pub lease: Duration,
}

impl Default for Retries {
    /// 8 tries over about 21 minutes: 10 s, 20 s, … 640 s apart.
    fn default() -> Retries {
        Retries {
            attempts: 8,
            first: Duration::from_secs(10),
            max: Duration::from_secs(3600),
            lease: 3 * WEBHOOK_TIMEOUT,
        }
    }
}

impl Retries {
    /// The wait after failed try number `attempt` (1-based): `first · 2^(attempt−1)`,
    /// at most `max`.
    pub fn wait(&self, attempt: i64) -> Duration {
        let doublings = attempt.clamp(1, 32) as u32 - 1;
        self.first
            .saturating_mul(2u32.saturating_pow(doublings))
            .min(self.max)
    }
}
/// Longest webhook URL accepted, bytes.
pub const WEBHOOK_URL_MAX: usize = 2000;
/// Shortest and longest webhook secret accepted, characters (visible ASCII).
pub const WEBHOOK_SECRET_MIN: usize = 16;
pub const WEBHOOK_SECRET_MAX: usize = 256;
/// The header of a delivery's signature (see the module documentation).
pub const SIGNATURE_HEADER: &str = "Mtcal-Signature";

/// The signature header's value of `body` sent at `timestamp` (Unix seconds) with
/// `secret`: `t=<timestamp>,v1=<hex of HMAC-SHA256(secret, "<timestamp>.<body>")>`.
pub fn signature(secret: &str, timestamp: i64, body: &[u8]) -> String {
    let mut mac =
        Hmac::<Sha256>::new_from_slice(secret.as_bytes()).expect("HMAC takes a key of any size");
    mac.update(timestamp.to_string().as_bytes());
    mac.update(b".");
    mac.update(body);
    format!(
        "t={timestamp},v1={}",
        hex::encode(mac.finalize().into_bytes())
    )
}

/// Checks a webhook secret given by a client: [`WEBHOOK_SECRET_MIN`] to
/// [`WEBHOOK_SECRET_MAX`] visible ASCII characters (no spaces); the message never
/// repeats the secret.
pub fn validate_secret(secret: &str) -> Result<(), String> {
    let n = secret.chars().count();
    if !(WEBHOOK_SECRET_MIN..=WEBHOOK_SECRET_MAX).contains(&n) {
        return Err(format!(
            "webhook_secret: {WEBHOOK_SECRET_MIN} to {WEBHOOK_SECRET_MAX} characters, got {n}"
        ));
    }
    if !secret.chars().all(|c| c.is_ascii_graphic()) {
        return Err(
            "webhook_secret: visible ASCII characters only (no spaces or control characters)"
                .into(),
        );
    }
    Ok(())
}

/// One entry of the operator's allow-list: a host name as the URL writes it, or a
/// network (an address alone is a network of one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Allowed {
    Host(String),
    Net(IpNet),
}

impl std::str::FromStr for Allowed {
    type Err = String;

    /// `hooks.plant.local`, `10.1.2.3`, `10.0.0.0/8`, `fd00::/8`, `[::1]`.
    fn from_str(s: &str) -> Result<Allowed, String> {
        let s = s.trim();
        let bare = s.trim_start_matches('[').trim_end_matches(']');
        if let Ok(net) = bare.parse::<IpNet>() {
            return Ok(Allowed::Net(net));
        }
        if let Ok(ip) = bare.parse::<IpAddr>() {
            return Ok(Allowed::Net(IpNet::from(ip)));
        }
        let host = s.trim_end_matches('.').to_ascii_lowercase();
        let name_char = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '_';
        if host.is_empty() || !host.chars().all(name_char) {
            return Err(format!(
                "webhook allow-list: {s:?} is neither a host name, an address nor a network"
            ));
        }
        Ok(Allowed::Host(host))
    }
}

/// Where webhooks may go (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct TargetPolicy {
    /// Hosts and networks an operator allows although they are not public
    /// (`MTCAL_WEBHOOK_ALLOW`, comma-separated).
    pub allow: Vec<Allowed>,
    /// The service's own listening addresses and its database's: refused even when the
    /// allow-list names the host ([`TargetPolicy::is_own`]).
    pub own: Vec<SocketAddr>,
}

impl TargetPolicy {
    /// The policy of a comma-separated allow-list (empty: public addresses only).
    pub fn with_allow_list(list: &str) -> Result<TargetPolicy, String> {
        let allow = list
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        Ok(TargetPolicy { allow, own: vec![] })
    }

    fn allows_host(&self, host: &str) -> bool {
        self.allow
            .iter()
            .any(|a| matches!(a, Allowed::Host(h) if h == host))
    }

    /// Whether `a` reaches one of [`TargetPolicy::own`]: the same port on the same
    /// address, on any address when the service listens on all of them, or on a
    /// loopback address (which reaches whatever listens on this host).
    pub fn is_own(&self, a: SocketAddr) -> bool {
        self.own.iter().any(|o| {
            o.port() == a.port()
                && (o.ip() == a.ip() || o.ip().is_unspecified() || a.ip().is_loopback())
        })
    }

    fn allows_ip(&self, ip: IpAddr) -> bool {
        self.allow
            .iter()
            .any(|a| matches!(a, Allowed::Net(n) if n.contains(&ip)))
    }
}

/// Why `ip` is no webhook target unless an operator allows it (`None`: a public address).
pub fn reserved(ip: IpAddr) -> Option<&'static str> {
    fn v4(ip: Ipv4Addr) -> Option<&'static str> {
        let [a, b, ..] = ip.octets();
        Some(if ip.is_unspecified() || a == 0 {
            "unspecified"
        } else if ip.is_loopback() {
            "loopback"
        } else if ip.is_private() {
            "private"
        } else if ip.is_link_local() {
            "link-local"
        } else if a == 100 && (64..128).contains(&b) {
            "shared (carrier-grade NAT)"
        } else if ip.is_multicast() {
            "multicast"
        } else if ip.is_broadcast() {
            "broadcast"
        } else if ip.is_documentation() || (a == 192 && b == 0 && ip.octets()[2] == 0) {
            "documentation or protocol"
        } else if a >= 240 || (a == 198 && (b == 18 || b == 19)) {
            "reserved"
        } else if a == 192 && b == 88 && ip.octets()[2] == 99 {
            "6to4 relay anycast (deprecated)"
        } else {
            return None;
        })
    }
    fn v6(ip: Ipv6Addr) -> Option<&'static str> {
        if let Some(v) = ip.to_ipv4_mapped() {
            return v4(v);
        }
        let s = ip.segments();
        let embedded = |hi: u16, lo: u16| Ipv4Addr::from(((hi as u32) << 16) | lo as u32);
        // NAT64 (64:ff9b::/96): the IPv4 address it leads to.
        if s[..6] == [0x64, 0xff9b, 0, 0, 0, 0] {
            return v4(embedded(s[6], s[7]));
        }
        Some(if ip.is_unspecified() {
            "unspecified"
        } else if ip.is_loopback() {
            "loopback"
        } else if s[..6] == [0; 6] {
            // ::a.b.c.d, deprecated (RFC 4291 2.5.5.1): no route leads there.
            "IPv4-compatible (deprecated)"
        } else if s[0] == 0x2002 {
            // 6to4 (RFC 3056, deprecated by RFC 7526): the relay leads to the IPv4
            // address in bits 16-47, which may be any of those refused above.
            v4(embedded(s[1], s[2])).unwrap_or("6to4 (deprecated relay)")
        } else if s[0] == 0x2001 && s[1] == 0 {
            "Teredo (tunnel to an address hidden in the address)"
        } else if s[..3] == [0x64, 0xff9b, 1] {
            "NAT64 local-use"
        } else if ip.is_multicast() {
            "multicast"
        } else if s[0] & 0xfe00 == 0xfc00 {
            "private (unique local)"
        } else if s[0] & 0xffc0 == 0xfe80 {
            "link-local"
        } else if s[0] & 0xffc0 == 0xfec0 {
            "site-local (deprecated)"
        } else if (s[0] == 0x2001 && s[1] == 0x0db8) || (s[0] == 0x3fff && s[1] < 0x1000) {
            "documentation or protocol"
        } else if s[0] == 0x2001 && s[1] < 0x0200 {
            // 2001::/23, IETF protocol assignments (benchmarking, ORCHID, AMT, ...).
            "documentation or protocol"
        } else if s[..4] == [0x100, 0, 0, 0] || s[0] == 0x5f00 {
            // Discard-only (RFC 6666), SRv6 segment identifiers (RFC 9602).
            "reserved"
        } else {
            return None;
        })
    }
    match ip {
        IpAddr::V4(ip) => v4(ip),
        IpAddr::V6(ip) => v6(ip),
    }
}

/// Checks a webhook target's form: an absolute `http` or `https` URL with a host and no
/// credentials, at most [`WEBHOOK_URL_MAX`] bytes; the message says what is wrong.
pub fn validate_webhook_url(url: &str) -> Result<(), String> {
    parse(url).map(|_| ())
}

fn parse(url: &str) -> Result<reqwest::Url, String> {
    if url.len() > WEBHOOK_URL_MAX {
        return Err(format!(
            "webhook_url: at most {WEBHOOK_URL_MAX} bytes, got {}",
            url.len()
        ));
    }
    if let Some(c) = url.chars().find(|c| c.is_control() || c.is_whitespace()) {
        return Err(format!(
            "webhook_url: holds {} (U+{:04X}); write a URL without blanks or control \
             characters (percent-encode them)",
            if c.is_control() {
                "a control character"
            } else {
                "a blank"
            },
            c as u32
        ));
    }
    let u =
        reqwest::Url::parse(url).map_err(|e| format!("webhook_url: not an absolute URL ({e})"))?;
    if !matches!(u.scheme(), "http" | "https") {
        return Err(format!(
            "webhook_url: the scheme must be http or https, got {:?}",
            u.scheme()
        ));
    }
    if u.host_str().is_none_or(str::is_empty) {
        return Err("webhook_url: the URL names no host".into());
    }
    if !u.username().is_empty() || u.password().is_some() {
        return Err(
            "webhook_url: no credentials in the URL (user:password@); the receiver checks \
             the delivery's signature instead"
                .into(),
        );
    }
    Ok(u)
}

/// A webhook URL as logs show it: scheme, host, port and path (no query, no fragment).
pub fn shown(url: &str) -> String {
    match reqwest::Url::parse(url) {
        Ok(mut u) => {
            u.set_query(None);
            u.set_fragment(None);
            let _ = u.set_password(None);
            let _ = u.set_username("");
            u.to_string()
        }
        Err(_) => "(not a URL)".into(),
    }
}

/// A webhook URL as a read key sees it: scheme, host and port only (its path and query
/// may carry a receiver's token).
pub fn host_only(url: &str) -> String {
    match reqwest::Url::parse(url) {
        Ok(u) => {
            let port = u.port().map(|p| format!(":{p}")).unwrap_or_default();
            format!("{}://{}{port}/", u.scheme(), u.host_str().unwrap_or(""))
        }
        Err(_) => "(not a URL)".into(),
    }
}

/// The addresses `url` may be delivered to under `policy`, resolved now; refused, with
/// the address and the rule named, when one of them is not allowed (see the module
/// documentation).
pub async fn resolve(
    url: &str,
    policy: &TargetPolicy,
) -> Result<(reqwest::Url, Vec<SocketAddr>), String> {
    let u = parse(url)?;
    let port = u.port_or_known_default().unwrap_or(80);
    let (name, addrs): (String, Vec<SocketAddr>) = match u.host() {
        Some(url::Host::Ipv4(ip)) => (ip.to_string(), vec![SocketAddr::new(ip.into(), port)]),
        Some(url::Host::Ipv6(ip)) => (ip.to_string(), vec![SocketAddr::new(ip.into(), port)]),
        Some(url::Host::Domain(d)) => {
            let d = d.trim_end_matches('.').to_ascii_lowercase();
            let found: Vec<SocketAddr> =
                tokio::time::timeout(WEBHOOK_TIMEOUT, tokio::net::lookup_host((d.as_str(), port)))
                    .await
                    .map_err(|_| {
                        format!("webhook_url: resolving {d} took over {WEBHOOK_TIMEOUT:?}")
                    })?
                    .map_err(|e| format!("webhook_url: {d} cannot be resolved ({e})"))?
                    .collect();
            (d, found)
        }
        None => return Err("webhook_url: the URL names no host".into()),
    };
    if addrs.is_empty() {
        return Err(format!("webhook_url: {name} resolves to no address"));
    }
    let by_name = policy.allows_host(&name);
    for a in &addrs {
        if policy.is_own(*a) {
            return Err(format!(
                "webhook_url: {name} is {a}, this service itself or its database; webhooks \
                 go elsewhere"
            ));
        }
        if by_name || policy.allows_ip(a.ip()) {
            continue;
        }
        if let Some(kind) = reserved(a.ip()) {
            return Err(format!(
                "webhook_url: {name} is {}, a {kind} address: webhooks go to public \
                 addresses unless the operator allows this one (MTCAL_WEBHOOK_ALLOW)",
                a.ip()
            ));
        }
    }
    Ok((u, addrs))
}

/// The addresses of a PostgreSQL database URL's host (port 5432 when none is given), which
/// no webhook may reach, allow-listed or not ([`TargetPolicy::own`]); none for SQLite or
/// a host that does not resolve now.
pub async fn database_addrs(db_url: &str) -> Vec<SocketAddr> {
    let Ok(u) = reqwest::Url::parse(db_url) else {
        return vec![];
    };
    if !matches!(u.scheme(), "postgres" | "postgresql") {
        return vec![];
    }
    let Some(host) = u.host_str().filter(|h| !h.is_empty()) else {
        return vec![];
    };
    let host = host.trim_start_matches('[').trim_end_matches(']');
    let port = u.port().unwrap_or(5432);
    match tokio::net::lookup_host((host, port)).await {
        Ok(found) => found.collect(),
        Err(_) => vec![],
    }
}

/// A webhook to tell: its profile, URL and signing secret (`None`: a profile written
/// before webhooks had secrets; its deliveries go unsigned).
#[derive(Clone, PartialEq)]
pub struct Target {
    pub profile_id: String,
    pub url: String,
    pub secret: Option<String>,
}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Target")
            .field("profile_id", &self.profile_id)
            .field("url", &shown(&self.url))
            .finish_non_exhaustive()
    }
}

/// The webhooks of the tag profiles of `tags` (each URL once, from the first profile
/// naming it).
pub fn targets(profiles: &[mtcal_store::ToleranceProfile], tags: &[String]) -> Vec<Target> {
    let mut found: Vec<Target> = vec![];
    for p in profiles
        .iter()
        .filter(|p| p.scope == "tag" && tags.contains(&p.target))
    {
        if let Some(url) = &p.webhook_url
            && !found.iter().any(|t| &t.url == url)
        {
            found.push(Target {
                profile_id: p.id.clone(),
                url: url.clone(),
                secret: p.webhook_secret.clone(),
            });
        }
    }
    found
}

/// A client that connects `u`'s host to `addrs` only (the addresses just checked).
fn client(u: &reqwest::Url, addrs: &[SocketAddr]) -> reqwest::Result<reqwest::Client> {
    let mut b = reqwest::Client::builder()
        .timeout(WEBHOOK_TIMEOUT)
        .connect_timeout(WEBHOOK_TIMEOUT)
        .redirect(reqwest::redirect::Policy::none())
        .no_proxy()
        .user_agent(concat!("mtcal/", env!("CARGO_PKG_VERSION")));
    if let Some(url::Host::Domain(d)) = u.host() {
        b = b.resolve_to_addrs(d, addrs);
    }
    b.build()
}

/// Why a try failed, and whether trying again may help.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TryError {
    pub message: String,
    /// The target is refused: no further try.
    pub refused: bool,
}

/// One try: POSTs the JSON `body` to `to`, signed with its secret, when `policy` allows
/// the target (checked now); `Ok` on a 2xx answer.
pub async fn try_once(to: &Target, policy: &TargetPolicy, body: &str) -> Result<(), TryError> {
    let (u, addrs) = resolve(&to.url, policy).await.map_err(|message| TryError {
        message,
        refused: true,
    })?;
    let failed = |message: String| TryError {
        message,
        refused: false,
    };
    let c = client(&u, &addrs).map_err(|e| failed(e.without_url().to_string()))?;
    let mut post = c
        .post(u)
        .header(reqwest::header::CONTENT_TYPE, "application/json");
    if let Some(secret) = &to.secret {
        let t = mtcal_store::now_ms().div_euclid(1000);
        post = post.header(SIGNATURE_HEADER, signature(secret, t, body.as_bytes()));
    }
    match post.body(body.to_string()).send().await {
        Ok(r) if r.status().is_success() => Ok(()),
        Ok(r) => Err(failed(format!("answered {}", r.status()))),
        Err(e) => Err(failed(e.without_url().to_string())),
    }
}

/// Longest `last_error` kept, characters.
const ERROR_MAX: usize = 500;

/// Claims the next due delivery of the outbox, tries it once under `policy` and records
/// the outcome by `retries` (see the module documentation); `false` when none was due.
pub async fn deliver_next(
    store: &dyn mtcal_store::Store,
    policy: &TargetPolicy,
    retries: &Retries,
) -> Result<bool, mtcal_store::StoreError> {
    use mtcal_store::DeliveryOutcome;
    let lease = retries.lease.as_millis() as i64;
    let Some(d) = store.claim_delivery(lease).await? else {
        return Ok(false);
    };
    let target = shown(&d.url);
    let secret = match store.get_tolerance(&d.profile_id).await {
        Ok(p) => Ok(p.webhook_secret),
        Err(mtcal_store::StoreError::NotFound(_)) => Err(TryError {
            message: format!("its tolerance profile {} was deleted", d.profile_id),
            refused: true,
        }),
        Err(e) => return Err(e),
    };
    let to = secret.map(|secret| Target {
        profile_id: d.profile_id.clone(),
        url: d.url.clone(),
        secret,
    });
    let tried = match &to {
        Ok(to) => try_once(to, policy, &d.body).await,
        Err(e) => Err(e.clone()),
    };
    let (alert, attempt) = (&d.alert_id, d.attempts);
    let outcome = match tried {
        Ok(()) => {
            tracing::info!(%alert, %target, attempt, "webhook delivered");
            DeliveryOutcome::Delivered
        }
        Err(e) => {
            let error: String = e.message.chars().take(ERROR_MAX).collect();
            if e.refused || attempt >= i64::from(retries.attempts) {
                tracing::warn!(%alert, %target, attempt, %error, "webhook given up");
                DeliveryOutcome::Failed { error }
            } else {
                let wait = retries.wait(attempt);
                tracing::warn!(%alert, %target, attempt, %error, ?wait, "webhook try failed");
                DeliveryOutcome::Retry {
                    after_ms: wait.as_millis() as i64,
                    error,
                }
            }
        }
    };
    store.finish_delivery(&d.id, attempt, &outcome).await?;
    Ok(true)
}

/// Most deliveries one list returns.
pub const MAX_DELIVERIES: usize = 1000;

/// The state of a webhook delivery (mtcal_store::DELIVERY_STATES).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum DeliveryState {
    /// To be tried at `next_attempt_at`.
    Pending,
    /// A try was answered 2xx.
    Delivered,
    /// Its tries are used up, or its target was refused.
    Failed,
}

impl DeliveryState {
    pub fn as_str(self) -> &'static str {
        match self {
            DeliveryState::Pending => "pending",
            DeliveryState::Delivered => "delivered",
            DeliveryState::Failed => "failed",
        }
    }
}

/// A webhook delivery as the API shows it (to write keys): never the body's signature,
/// the secret, or the URL's query.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DeliveryView {
    pub id: String,
    /// The drift alert delivered.
    pub alert_id: String,
    /// The tag profile whose webhook it goes to.
    pub profile_id: String,
    /// The webhook's URL without query or fragment.
    pub url: String,
    pub state: DeliveryState,
    /// Tries made so far.
    pub attempts: i64,
    /// When a pending delivery is tried next (RFC 3339, the database's clock); absent
    /// once it is delivered or failed.
    pub next_attempt_at: Option<String>,
    /// Why the last try failed.
    pub last_error: Option<String>,
    pub created_at: String,
    /// When its state last changed.
    pub updated_at: String,
}

impl DeliveryView {
    pub fn of(d: &mtcal_store::WebhookDelivery) -> DeliveryView {
        let at = |ms: i64| {
            time::OffsetDateTime::from_unix_timestamp_nanos(i128::from(ms) * 1_000_000)
                .ok()
                .and_then(|t| {
                    t.format(&time::format_description::well_known::Rfc3339)
                        .ok()
                })
        };
        DeliveryView {
            id: d.id.clone(),
            alert_id: d.alert_id.clone(),
            profile_id: d.profile_id.clone(),
            url: shown(&d.url),
            state: match d.state.as_str() {
                "pending" => DeliveryState::Pending,
                "delivered" => DeliveryState::Delivered,
                _ => DeliveryState::Failed,
            },
            attempts: d.attempts,
            next_attempt_at: (d.state == "pending")
                .then(|| at(d.next_attempt_ms))
                .flatten(),
            last_error: d.last_error.clone(),
            created_at: d.created_at.clone(),
            updated_at: d.updated_at.clone(),
        }
    }
}

/// Which deliveries a list holds.
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct DeliveryQuery {
    /// Only this alert's deliveries.
    pub alert_id: Option<String>,
    /// Only deliveries in this state.
    pub state: Option<DeliveryState>,
    /// At most this many, newest first (default 100, at most 1000).
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 1000))]
    pub limit: Option<usize>,
}

/// Deliveries newest first (`GET /api/v1/webhooks/deliveries`).
pub async fn list(
    store: &dyn mtcal_store::Store,
    q: &DeliveryQuery,
) -> Result<Vec<DeliveryView>, DomainError> {
    let limit = crate::paging::limit(q.limit, 100, MAX_DELIVERIES)?;
    let rows = store
        .list_deliveries(
            q.alert_id.as_deref(),
            q.state.map(DeliveryState::as_str),
            limit as i64,
        )
        .await?;
    Ok(rows.iter().map(DeliveryView::of).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn webhook_targets_are_http_urls_without_credentials() {
        for ok in [
            "http://127.0.0.1:8080/hook",
            "https://alerts.example.com/mtcal?x=1",
        ] {
            validate_webhook_url(ok).unwrap();
        }
        for (bad, says) in [
            ("ftp://example.com/x", "scheme"),
            ("file:///etc/passwd", "scheme"),
            ("/relative/path", "absolute"),
            ("http://", "absolute"),
            ("not a url", "blank"),
            ("not-a-url", "absolute"),
            ("https://user:pw@alerts.example.com/x", "credentials"),
            ("https://token@alerts.example.com/x", "credentials"),
            ("https://alerts.example.com/a\tb", "control character"),
            ("https://alerts.example.com/a\nb", "control character"),
            ("https://alerts.example.com/\u{85}", "control character"),
            ("https://alerts.example.com/a b", "blank"),
        ] {
            let e = validate_webhook_url(bad).unwrap_err();
            assert!(
                e.starts_with("webhook_url:") && e.contains(says),
                "{bad}: {e}"
            );
        }
        let long = format!("http://127.0.0.1/{}", "a".repeat(WEBHOOK_URL_MAX));
        assert!(validate_webhook_url(&long).unwrap_err().contains("at most"));
        assert_eq!(
            shown("https://u:p@hooks.example.com:8443/a/b?token=s3cret#f"),
            "https://hooks.example.com:8443/a/b"
        );
        assert_eq!(
            host_only("https://hooks.example.com:8443/a/b?token=s3cret"),
            "https://hooks.example.com:8443/"
        );
        assert_eq!(host_only("http://[::1]/x"), "http://[::1]/");
    }

    #[test]
    fn retries_double_up_to_their_longest_wait() {
        let r = Retries::default();
        let waits: Vec<u64> = (1..=8).map(|a| r.wait(a).as_secs()).collect();
        assert_eq!(waits, [10, 20, 40, 80, 160, 320, 640, 1280]);
        assert_eq!(r.wait(40), Duration::from_secs(3600));
        assert_eq!(r.wait(0), Duration::from_secs(10));
    }

    /// The signature is HMAC-SHA256 of `<t>.<body>`: the expected value was computed
    /// outside this code, by `printf '%s' '1700000000.{"id":"alert_1"}' | openssl dgst
    /// -sha256 -hmac whsec_test_0123456789`.
    #[test]
    fn a_signature_is_the_hmac_of_timestamp_and_body() {
        assert_eq!(
            signature(
                "whsec_test_0123456789",
                1_700_000_000,
                br#"{"id":"alert_1"}"#
            ),
            "t=1700000000,v1=50b8ec900a0a77cb589535490a94993b5ce3688f520a79898e4fdc6936ed2941"
        );
        validate_secret("whsec_test_0123456789").unwrap();
        for (bad, says) in [
            ("short", "16 to 256"),
            (&"x".repeat(257)[..], "16 to 256"),
            ("sixteen chars with spaces", "visible ASCII"),
            ("sixteen-chars\u{7f}-del", "visible ASCII"),
        ] {
            let e = validate_secret(bad).unwrap_err();
            assert!(
                e.starts_with("webhook_secret:") && e.contains(says),
                "{bad}: {e}"
            );
            assert!(!e.contains(bad), "the message repeats the secret: {e}");
        }
    }

    /// The audit's targets (and their relatives) are refused without an allow-list,
    /// whatever form the address takes; public addresses pass; no DNS is needed but
    /// for `localhost`, which every resolver answers locally.
    #[tokio::test]
    async fn private_and_local_targets_are_refused_unless_allowed() {
        let none = TargetPolicy::default();
        for (url, kind) in [
            ("http://169.254.169.254/latest/meta-data/", "link-local"),
            ("http://10.0.0.1/", "private"),
            ("http://172.16.5.4/", "private"),
            ("http://192.168.1.1/", "private"),
            ("http://[::1]:5432/", "loopback"),
            ("http://localhost:5432/", "loopback"),
            ("http://2130706433/", "loopback"),
            ("http://0x7f.1/", "loopback"),
            ("http://0177.0.0.1/", "loopback"),
            ("http://127.1/", "loopback"),
            ("http://0.0.0.0:8080/", "unspecified"),
            ("http://[::]/", "unspecified"),
            ("http://[::ffff:127.0.0.1]/", "loopback"),
            ("http://[::ffff:a9fe:a9fe]/", "link-local"),
            ("http://[64:ff9b::a9fe:a9fe]/", "link-local"),
            ("http://[fe80::1]/", "link-local"),
            ("http://[fd00::1]/", "private"),
            ("http://224.0.0.1/", "multicast"),
            ("http://[ff02::1]/", "multicast"),
            ("http://255.255.255.255/", "broadcast"),
            ("http://100.64.0.1/", "carrier-grade NAT"),
            // IPv6 forms that carry or hide an IPv4 address, and deprecated ranges.
            ("http://[::127.0.0.1]/", "IPv4-compatible"),
            ("http://[::a9fe:a9fe]/", "IPv4-compatible"),
            ("http://[2002:7f00:1::]/", "loopback"),
            ("http://[2002:a9fe:a9fe::1]/", "link-local"),
            ("http://[2002:c0a8:101::]/", "private"),
            ("http://[2002:5db8:d70e::1]/", "6to4"),
            ("http://[2001:0:4136:e378:8000:63bf:3fff:fdd2]/", "Teredo"),
            ("http://[64:ff9b::7f00:1]/", "loopback"),
            ("http://[64:ff9b:1::a00:1]/", "NAT64 local-use"),
            ("http://[fec0::1]/", "site-local"),
            ("http://[2001:2::1]/", "protocol"),
            ("http://[3fff::1]/", "documentation"),
            ("http://[100::1]/", "reserved"),
            ("http://192.88.99.1/", "6to4 relay"),
        ] {
            let e = resolve(url, &none).await.unwrap_err();
            assert!(
                e.contains(kind) && e.contains("MTCAL_WEBHOOK_ALLOW"),
                "{url}: {e}"
            );
        }
        for url in ["http://93.184.215.14/hook", "https://[2606:4700::1111]/x"] {
            let (_, addrs) = resolve(url, &none).await.unwrap();
            assert_eq!(addrs.len(), 1, "{url}");
        }
        // The service's own address, even a public one.
        let own: SocketAddr = "93.184.215.14:8080".parse().unwrap();
        let me = TargetPolicy {
            own: vec![own],
            ..TargetPolicy::default()
        };
        let e = resolve("http://93.184.215.14:8080/api/v1/keys", &me)
            .await
            .unwrap_err();
        assert!(e.contains("this service itself"), "{e}");
        resolve("http://93.184.215.14:9090/", &me).await.unwrap();
        // An allow-listed host does not open the service's own port or the database's,
        // whichever loopback address or name reaches them.
        let mut local = TargetPolicy::with_allow_list("127.0.0.0/8, localhost").unwrap();
        local.own = vec![
            "0.0.0.0:8080".parse().unwrap(),
            "10.0.0.5:5432".parse().unwrap(),
        ];
        for url in [
            "http://127.0.0.1:8080/api/v1/keys",
            "http://127.0.0.2:8080/",
            "http://localhost:8080/",
        ] {
            let e = resolve(url, &local).await.unwrap_err();
            assert!(
                e.contains("this service itself or its database"),
                "{url}: {e}"
            );
        }
        resolve("http://127.0.0.1:9000/hook", &local).await.unwrap();
        assert!(local.is_own("10.0.0.5:5432".parse().unwrap()));
        assert!(local.is_own("127.0.0.1:5432".parse().unwrap()));
        assert!(!local.is_own("10.0.0.6:5432".parse().unwrap()));
    }

    #[tokio::test]
    async fn the_database_of_a_postgres_url_is_protected() {
        assert_eq!(
            database_addrs("postgres://mtcal:pw@127.0.0.1:6543/mtcal").await,
            ["127.0.0.1:6543".parse::<SocketAddr>().unwrap()]
        );
        assert_eq!(
            database_addrs("postgresql://[::1]/mtcal").await,
            ["[::1]:5432".parse::<SocketAddr>().unwrap()]
        );
        assert!(database_addrs("mtcal.sqlite").await.is_empty());
        assert!(
            database_addrs("sqlite:///var/lib/mtcal/db")
                .await
                .is_empty()
        );
    }

    #[tokio::test]
    async fn the_allow_list_names_hosts_addresses_and_networks() {
        let p = TargetPolicy::with_allow_list(" 127.0.0.1, 10.0.0.0/8 ,Localhost., [::1]").unwrap();
        for url in [
            "http://127.0.0.1:9000/x",
            "http://10.200.3.4/",
            "http://localhost:5432/",
            "http://[::1]/",
        ] {
            resolve(url, &p)
                .await
                .unwrap_or_else(|e| panic!("{url}: {e}"));
        }
        for url in [
            "http://127.0.0.2/",
            "http://192.168.0.1/",
            "http://[fd00::1]/",
        ] {
            assert!(resolve(url, &p).await.is_err(), "{url}");
        }
        for bad in ["a b", "http://x/", "10.0.0.0/99"] {
            assert!(TargetPolicy::with_allow_list(bad).is_err(), "{bad}");
        }
    }

    /// A delivery checks the target again: a profile saved when a host was allowed
    /// is not delivered once the allow-list no longer names it (as when a name is
    /// repointed at a private address), and nothing connects.
    #[tokio::test]
    async fn a_delivery_checks_its_target_again() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}/hook", listener.local_addr().unwrap());
        let seen = tokio::spawn(async move {
            tokio::time::timeout(Duration::from_secs(2), listener.accept())
                .await
                .is_ok()
        });
        let to = Target {
            profile_id: "tol_1".into(),
            url,
            secret: None,
        };
        let e = try_once(&to, &TargetPolicy::default(), "{}")
            .await
            .unwrap_err();
        assert!(e.refused && e.message.contains("loopback"), "{e:?}");
        assert!(!seen.await.unwrap(), "a refused target was connected to");
    }
}
