//! The viewer's HTTP/1.1 server: a thread per connection over one listening socket, requests
//! parsed by `httparse` (hyper's parser), one request per connection.
//!
//! Written here over `httparse` rather than taken whole from a server crate because the
//! viewer's safety rules are about bounds: tiny_http 0.12 buffers a header line without limit
//! and starts a thread for every connection, and hyper or axum bring an async runtime to serve
//! what is one blocking render queue. Here a request head larger than [`MAX_HEAD_BYTES`] gets
//! 431, a head not received within [`HEAD_DEADLINE`] gets 408 (however slowly it trickles),
//! and the connections open at once are capped per client and in all: at a cap, the oldest
//! connection that is not waiting for a render is closed to make room, so slow or idle
//! clients cannot lock out one that sends its request at once.

use std::io::{ErrorKind, Read, Write};
use std::net::{IpAddr, SocketAddr, TcpListener, TcpStream};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::answers::Reply;

/// The largest request head (request line and headers) read.
pub const MAX_HEAD_BYTES: usize = 16 * 1024;
/// Connections open at once, in all and from one address.
pub const MAX_CONNECTIONS: usize = 256;
/// See [`MAX_CONNECTIONS`].
pub const MAX_PER_CLIENT: usize = 128;
/// How long a client may take to send its whole request head.
pub const HEAD_DEADLINE: Duration = Duration::from_secs(10);
/// How long a client may take to take the whole reply.
const REPLY_DEADLINE: Duration = Duration::from_secs(30);
/// Stack of a connection thread (parsing and the queue's wait; renders run elsewhere).
const CONNECTION_STACK: usize = 256 * 1024;

/// Answers a request's URL (`GET` or `HEAD`); a handler that waits for work may ask the
/// [`Client`] whether anyone still waits for the answer.
pub type Handler = dyn Fn(&str, &Client) -> Reply + Send + Sync;

/// The connection a request came on, while its handler runs.
pub struct Client {
    stream: TcpStream,
}

impl Client {
    /// Whether the client has closed or reset its connection. The socket is non-blocking
    /// while the handler runs, so this never waits.
    pub fn gone(&self) -> bool {
        match self.stream.peek(&mut [0u8; 1]) {
            Ok(0) => true,
            Ok(_) => false,
            Err(e) => e.kind() != ErrorKind::WouldBlock && e.kind() != ErrorKind::Interrupted,
        }
    }

    /// A client over `stream`, which the test must have made non-blocking.
    #[cfg(test)]
    pub fn for_tests(stream: TcpStream) -> Self {
        Self { stream }
    }

    /// Another handle on the same connection (for a job that outlives the handler's frame).
    pub fn try_clone(&self) -> std::io::Result<Self> {
        Ok(Self { stream: self.stream.try_clone()? })
    }
}

/// Serves `handler` on `listener` from a thread per connection; returns at once.
/// `allowed_hosts`, when given, are the only `Host` headers answered (a server bound to the
/// loopback refuses requests a web page sends it under another name: DNS rebinding).
pub fn spawn(listener: TcpListener, allowed_hosts: Option<Vec<String>>, handler: Arc<Handler>) -> std::io::Result<()> {
    let shared = Arc::new(Shared { hosts: allowed_hosts, handler, open: Mutex::new(Open::default()) });
    std::thread::Builder::new().name("lucid-view-accept".into()).spawn(move || {
        loop {
            match listener.accept() {
                Ok((stream, peer)) => admit(&shared, stream, peer.ip()),
                // Running out of descriptors or a reset before accept: try the next one.
                Err(e) => {
                    tracing::debug!("accept: {e}");
                    std::thread::sleep(Duration::from_millis(10));
                }
            }
        }
    })?;
    Ok(())
}

/// The `Host` values a browser sends to a server at `addr` when it is bound to the loopback.
pub fn loopback_hosts(addr: SocketAddr) -> Option<Vec<String>> {
    let port = addr.port();
    addr.ip()
        .is_loopback()
        .then(|| vec![format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")])
}

struct Shared {
    hosts: Option<Vec<String>>,
    handler: Arc<Handler>,
    open: Mutex<Open>,
}

/// The open connections, oldest first.
#[derive(Default)]
struct Open {
    next_id: u64,
    connections: Vec<Connection>,
}

struct Connection {
    id: u64,
    peer: IpAddr,
    /// A handle to close it by.
    stream: TcpStream,
    /// Set while its request is being answered (a render may wait for the model): such a
    /// connection is never closed early.
    waiting: Arc<AtomicBool>,
}

impl Open {
    /// Makes room for one more connection from `peer`: closes the oldest connection (of
    /// `peer` at its cap, else of anyone) not waiting for the model. False when every
    /// connection waits for the model.
    fn make_room(&mut self, peer: IpAddr) -> bool {
        let from_peer = self.connections.iter().filter(|c| c.peer == peer).count();
        let full = self.connections.len() >= MAX_CONNECTIONS;
        if from_peer < MAX_PER_CLIENT && !full {
            return true;
        }
        let victim =
            self.connections.iter().position(|c| (full || c.peer == peer) && !c.waiting.load(Ordering::Acquire));
        match victim {
            Some(i) => {
                let closed = self.connections.remove(i);
                let _ = closed.stream.shutdown(std::net::Shutdown::Both);
                true
            }
            None => false,
        }
    }

    fn remove(&mut self, id: u64) {
        self.connections.retain(|c| c.id != id);
    }
}

fn admit(shared: &Arc<Shared>, stream: TcpStream, peer: IpAddr) {
    let waiting = Arc::new(AtomicBool::new(false));
    let id = {
        let Ok(mut open) = shared.open.lock() else { return };
        let Ok(handle) = stream.try_clone() else { return };
        if !open.make_room(peer) {
            drop(open);
            refuse_busy(stream);
            return;
        }
        let id = open.next_id;
        open.next_id += 1;
        open.connections.push(Connection { id, peer, stream: handle, waiting: waiting.clone() });
        id
    };
    let shared_for_thread = shared.clone();
    let spawned =
        std::thread::Builder::new().name("lucid-view-conn".into()).stack_size(CONNECTION_STACK).spawn(move || {
            serve_connection(stream, &shared_for_thread, &waiting);
            if let Ok(mut open) = shared_for_thread.open.lock() {
                open.remove(id);
            }
        });
    if spawned.is_err()
        && let Ok(mut open) = shared.open.lock()
    {
        open.remove(id);
    }
}

/// Every connection waits for the model: this one is told so at once.
fn refuse_busy(mut stream: TcpStream) {
    let reply =
        Reply::text(503, "the viewer is busy with other clients' renders; try again").with("Retry-After", "1".into());
    let _ = write_reply(&mut stream, &reply, false, Instant::now() + Duration::from_secs(1));
}

fn serve_connection(mut stream: TcpStream, shared: &Shared, waiting: &AtomicBool) {
    let accepted = Instant::now();
    let (reply, head_only) = match read_request(&mut stream, accepted + HEAD_DEADLINE) {
        Ok(request) => answer(&request, &stream, shared, waiting),
        Err(refusal) => (refusal, false),
    };
    // The client may have gone; there is no one to tell.
    let _ = write_reply(&mut stream, &reply, head_only, Instant::now() + REPLY_DEADLINE);
    linger(&mut stream);
}

/// Closes the connection after the reply: whatever the client still sends (a body, the rest
/// of an oversized head) is read and dropped first, a bounded amount for a bounded time, since
/// closing a socket with unread input resets it and the client may lose the reply.
fn linger(stream: &mut TcpStream) {
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let deadline = Instant::now() + Duration::from_millis(500);
    let mut sink = [0u8; 8192];
    let mut left = 1 << 20;
    while left > 0 && set_read_deadline(stream, deadline) {
        match stream.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => left -= n.min(left),
        }
    }
}

/// Sets the socket's read timeout to the time left before `deadline`; false when none is.
fn set_read_deadline(stream: &TcpStream, deadline: Instant) -> bool {
    let left = deadline.saturating_duration_since(Instant::now());
    !left.is_zero() && stream.set_read_timeout(Some(left)).is_ok()
}

/// What the server needs of a request.
struct RequestHead {
    method: String,
    url: String,
    host: Option<String>,
    origin: Option<String>,
    fetch_site: Option<String>,
    has_body: bool,
}

fn read_request(stream: &mut TcpStream, deadline: Instant) -> Result<RequestHead, Reply> {
    let mut buffer = vec![0u8; MAX_HEAD_BYTES];
    let mut filled = 0;
    loop {
        let late = || Reply::text(408, "the request was not received in time");
        if !set_read_deadline(stream, deadline) {
            return Err(late());
        }
        let n = match stream.read(&mut buffer[filled..]) {
            Ok(0) => return Err(Reply::text(400, "the request ended before its headers did")),
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(_) => return Err(late()),
        };
        filled += n;
        match parse_head(&buffer[..filled]) {
            Ok(Some(head)) => return Ok(head),
            Ok(None) if filled == buffer.len() => {
                return Err(Reply::text(431, &format!("the request head is larger than {MAX_HEAD_BYTES} bytes")));
            }
            Ok(None) => {}
            Err(refusal) => return Err(refusal),
        }
    }
}

/// The request head in `bytes`, `None` while it is incomplete.
fn parse_head(bytes: &[u8]) -> Result<Option<RequestHead>, Reply> {
    let mut headers = [httparse::EMPTY_HEADER; 64];
    let mut request = httparse::Request::new(&mut headers);
    match request.parse(bytes) {
        Ok(httparse::Status::Complete(_)) => {
            let header = |name: &str| {
                request
                    .headers
                    .iter()
                    .find(|h| h.name.eq_ignore_ascii_case(name))
                    .map(|h| String::from_utf8_lossy(h.value).trim().to_string())
            };
            let has_body = header("transfer-encoding").is_some()
                || header("content-length").is_some_and(|v| v.parse::<u64>().map_or(true, |n| n > 0));
            Ok(Some(RequestHead {
                method: request.method.unwrap_or_default().to_string(),
                url: request.path.unwrap_or_default().to_string(),
                host: header("host"),
                origin: header("origin"),
                fetch_site: header("sec-fetch-site"),
                has_body,
            }))
        }
        Ok(httparse::Status::Partial) => Ok(None),
        Err(httparse::Error::TooManyHeaders) => Err(Reply::text(431, "more than 64 request headers")),
        Err(e) => Err(Reply::text(400, &format!("malformed request: {e}"))),
    }
}

/// [`parse_head`] for the fuzzers: `Ok` whether complete or not, or the refusal's status.
#[cfg(test)]
pub fn parse_head_for_tests(bytes: &[u8]) -> Result<(), u16> {
    parse_head(bytes).map(|_| ()).map_err(|reply| reply.status)
}

/// Why a request is refused before its URL is looked at, if it is.
fn refusal(request: &RequestHead, hosts: Option<&[String]>) -> Option<Reply> {
    if request.method != "GET" && request.method != "HEAD" {
        return Some(Reply::text(405, "only GET and HEAD are served").with("Allow", "GET, HEAD".into()));
    }
    if request.has_body {
        return Some(Reply::text(413, "requests to the viewer carry no body"));
    }
    if let Some(hosts) = hosts
        && !request.host.as_ref().is_some_and(|h| hosts.iter().any(|a| a.eq_ignore_ascii_case(h)))
    {
        return Some(Reply::text(403, "this viewer answers only requests addressed to it by its loopback address"));
    }
    // A browser names the page that sent a request: one from another site's page (a script,
    // an image tag) is refused, so no open web page can drive the viewer.
    let foreign_origin = request.origin.as_deref().is_some_and(|origin| {
        let host = request.host.as_deref().unwrap_or("");
        !origin.strip_prefix("http://").is_some_and(|o| o.eq_ignore_ascii_case(host))
    });
    let foreign_site = request.fetch_site.as_deref().is_some_and(|s| s == "cross-site" || s == "same-site");
    if foreign_origin || foreign_site {
        return Some(Reply::text(403, "this viewer answers only its own page, not requests from other web pages"));
    }
    None
}

fn answer(request: &RequestHead, stream: &TcpStream, shared: &Shared, waiting: &AtomicBool) -> (Reply, bool) {
    let head_only = request.method == "HEAD";
    if let Some(refused) = refusal(request, shared.hosts.as_deref()) {
        let head_only = head_only && refused.status != 405;
        return (refused, head_only);
    }
    let client = match stream.try_clone() {
        Ok(stream) => Client { stream },
        Err(e) => return (Reply::text(503, &format!("cannot serve this connection: {e}")), head_only),
    };
    if client.stream.set_nonblocking(true).is_err() {
        return (Reply::text(503, "cannot serve this connection"), head_only);
    }
    waiting.store(true, Ordering::Release);
    // A handler that panics answers 500; the server and whatever owns the model go on.
    let reply = catch_unwind(AssertUnwindSafe(|| (shared.handler)(&request.url, &client)))
        .unwrap_or_else(|panic| Reply::text(500, &format!("the request failed: {}", panic_message(&panic))));
    waiting.store(false, Ordering::Release);
    let _ = client.stream.set_nonblocking(false);
    (reply, head_only)
}

/// The message a panic carried.
pub fn panic_message(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "an internal error".into())
}

fn write_reply(stream: &mut TcpStream, reply: &Reply, head_only: bool, deadline: Instant) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n",
        reply.status,
        reason(reply.status),
        reply.content_type,
        reply.body.len()
    );
    for (name, value) in &reply.headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str("\r\n");
    write_before(stream, head.as_bytes(), deadline)?;
    if !head_only {
        write_before(stream, &reply.body, deadline)?;
    }
    stream.flush()
}

/// Writes all of `bytes` unless `deadline` passes first (a client that stops reading).
fn write_before(stream: &mut TcpStream, mut bytes: &[u8], deadline: Instant) -> std::io::Result<()> {
    while !bytes.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(ErrorKind::TimedOut.into());
        }
        stream.set_write_timeout(Some(left))?;
        match stream.write(bytes) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        413 => "Content Too Large",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Internal Server Error",
    }
}

/// Counts of open connections per address, for the tests.
#[cfg(test)]
fn per_peer(open: &Open) -> std::collections::HashMap<IpAddr, usize> {
    let mut counts = std::collections::HashMap::new();
    for c in &open.connections {
        *counts.entry(c.peer).or_insert(0) += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(text: &str) -> RequestHead {
        parse_head(text.as_bytes()).unwrap().expect("a whole head")
    }

    #[test]
    fn requests_from_other_pages_are_refused() {
        let hosts = loopback_hosts("127.0.0.1:7007".parse().unwrap());
        let ok = head("GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:7007\r\n\r\n");
        assert!(refusal(&ok, hosts.as_deref()).is_none());
        let own = head(
            "GET /api/info HTTP/1.1\r\nHost: localhost:7007\r\nOrigin: http://localhost:7007\r\n\
             Sec-Fetch-Site: same-origin\r\n\r\n",
        );
        assert!(refusal(&own, hosts.as_deref()).is_none());
        let typed = head("GET / HTTP/1.1\r\nHost: localhost:7007\r\nSec-Fetch-Site: none\r\n\r\n");
        assert!(refusal(&typed, hosts.as_deref()).is_none());
        for foreign in [
            "GET /api/render HTTP/1.1\r\nHost: 127.0.0.1:7007\r\nOrigin: https://evil.example\r\n\r\n",
            "GET /api/render HTTP/1.1\r\nHost: 127.0.0.1:7007\r\nOrigin: null\r\n\r\n",
            "GET /api/render HTTP/1.1\r\nHost: 127.0.0.1:7007\r\nSec-Fetch-Site: cross-site\r\n\r\n",
            "GET /api/render HTTP/1.1\r\nHost: evil.example\r\n\r\n",
            "GET /api/render HTTP/1.1\r\n\r\n",
        ] {
            let refused = refusal(&head(foreign), hosts.as_deref()).expect(foreign);
            assert_eq!(refused.status, 403, "{foreign}");
        }
        // Bound to all addresses there is no host list, but the origin must still match.
        let lan = head("GET / HTTP/1.1\r\nHost: 10.0.0.5:7007\r\nOrigin: http://10.0.0.5:7007\r\n\r\n");
        assert!(refusal(&lan, None).is_none());
        let cross = head("GET / HTTP/1.1\r\nHost: 10.0.0.5:7007\r\nOrigin: http://evil.example\r\n\r\n");
        assert_eq!(refusal(&cross, None).unwrap().status, 403);
    }

    #[test]
    fn a_full_server_closes_the_oldest_connection_not_waiting_for_the_model() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let mut open = Open::default();
        let mut clients = Vec::new();
        let peer: IpAddr = "127.0.0.1".parse().unwrap();
        for id in 0..MAX_PER_CLIENT as u64 {
            clients.push(TcpStream::connect(addr).unwrap());
            let (stream, _) = listener.accept().unwrap();
            // The first two wait for renders.
            let waiting = Arc::new(AtomicBool::new(id < 2));
            open.connections.push(Connection { id, peer, stream, waiting });
        }
        assert!(open.make_room(peer));
        let ids: Vec<u64> = open.connections.iter().map(|c| c.id).collect();
        assert!(ids.starts_with(&[0, 1, 3]) && !ids.contains(&2), "the oldest idle one (2) is closed");
        let mut byte = [0u8; 1];
        clients[2].set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(clients[2].read(&mut byte).unwrap(), 0, "its client sees the close");
        // Another address is under its own cap.
        let other: IpAddr = "127.0.0.2".parse().unwrap();
        assert!(open.make_room(other));
        assert_eq!(per_peer(&open)[&peer], MAX_PER_CLIENT - 1);
        // When every connection waits for the model there is no room.
        for c in &open.connections {
            c.waiting.store(true, Ordering::Release);
        }
        clients.push(TcpStream::connect(addr).unwrap());
        let (stream, _) = listener.accept().unwrap();
        open.connections.push(Connection { id: 999, peer, stream, waiting: Arc::new(AtomicBool::new(true)) });
        assert!(!open.make_room(peer));
    }
}
