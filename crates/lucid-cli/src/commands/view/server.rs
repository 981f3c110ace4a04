//! The viewer's HTTP/1.1 server: a fixed pool of connection threads over one listening socket,
//! requests parsed by `httparse` (hyper's parser), one request per connection.
//!
//! Written here over `httparse` rather than taken whole from a server crate because the
//! viewer's safety rules are about bounds: tiny_http 0.12 buffers a header line without limit
//! and starts a thread for every connection, and hyper or axum bring an async runtime to serve
//! what is one blocking render queue. Here a request head larger than [`MAX_HEAD_BYTES`] gets
//! 431, a slow client times out, and connections beyond the pool wait in the socket's backlog:
//! nothing a client sends makes the server allocate or spawn without bound.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::time::Duration;

use super::answers::Reply;

/// The largest request head (request line and headers) read.
pub const MAX_HEAD_BYTES: usize = 16 * 1024;
/// Connections served at once; more wait in the listening socket's backlog.
pub const CONNECTION_THREADS: usize = 8;
/// How long a client may take to send its request, or to take the reply.
const TIMEOUT: Duration = Duration::from_secs(20);

/// Answers a request's URL (`GET` or `HEAD`).
pub type Handler = dyn Fn(&str) -> Reply + Send + Sync;

/// Serves `handler` on `listener` from [`CONNECTION_THREADS`] threads; returns at once.
/// `allowed_hosts`, when given, are the only `Host` headers answered (a server bound to the
/// loopback refuses requests a web page sends it under another name: DNS rebinding).
pub fn spawn(listener: TcpListener, allowed_hosts: Option<Vec<String>>, handler: Arc<Handler>) -> std::io::Result<()> {
    let hosts = Arc::new(allowed_hosts);
    for i in 0..CONNECTION_THREADS {
        let listener = listener.try_clone()?;
        let (hosts, handler) = (hosts.clone(), handler.clone());
        std::thread::Builder::new().name(format!("lucid-view-{i}")).spawn(move || {
            loop {
                match listener.accept() {
                    Ok((stream, _)) => serve_connection(stream, hosts.as_deref(), handler.as_ref()),
                    // Running out of descriptors or a reset before accept: try the next one.
                    Err(e) => {
                        tracing::debug!("accept: {e}");
                        std::thread::sleep(Duration::from_millis(10));
                    }
                }
            }
        })?;
    }
    Ok(())
}

/// The `Host` values a browser sends to a server at `addr` when it is bound to the loopback.
pub fn loopback_hosts(addr: SocketAddr) -> Option<Vec<String>> {
    let port = addr.port();
    addr.ip()
        .is_loopback()
        .then(|| vec![format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")])
}

fn serve_connection(mut stream: TcpStream, hosts: Option<&[String]>, handler: &Handler) {
    let _ = stream.set_read_timeout(Some(TIMEOUT));
    let _ = stream.set_write_timeout(Some(TIMEOUT));
    let (reply, head_only) = match read_request(&mut stream) {
        Ok(request) => answer(&request, hosts, handler),
        Err(refusal) => (refusal, false),
    };
    // The client may have gone; there is no one to tell.
    let _ = write_reply(&mut stream, &reply, head_only);
    linger(&mut stream);
}

/// Closes the connection after the reply: whatever the client still sends (a body, the rest
/// of an oversized head) is read and dropped first, a bounded amount for a bounded time, since
/// closing a socket with unread input resets it and the client may lose the reply.
fn linger(stream: &mut TcpStream) {
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let _ = stream.set_read_timeout(Some(Duration::from_millis(500)));
    let mut sink = [0u8; 8192];
    let mut left = 1 << 20;
    while left > 0 {
        match stream.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => left -= n.min(left),
        }
    }
}

/// What the server needs of a request.
struct RequestHead {
    method: String,
    url: String,
    host: Option<String>,
    has_body: bool,
}

fn read_request(stream: &mut TcpStream) -> Result<RequestHead, Reply> {
    let mut buffer = vec![0u8; MAX_HEAD_BYTES];
    let mut filled = 0;
    loop {
        let n = match stream.read(&mut buffer[filled..]) {
            Ok(0) => return Err(Reply::text(400, "the request ended before its headers did")),
            Ok(n) => n,
            Err(_) => return Err(Reply::text(408, "the request was not received in time")),
        };
        filled += n;
        let mut headers = [httparse::EMPTY_HEADER; 64];
        let mut request = httparse::Request::new(&mut headers);
        match request.parse(&buffer[..filled]) {
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
                return Ok(RequestHead {
                    method: request.method.unwrap_or_default().to_string(),
                    url: request.path.unwrap_or_default().to_string(),
                    host: header("host"),
                    has_body,
                });
            }
            Ok(httparse::Status::Partial) if filled == buffer.len() => {
                return Err(Reply::text(431, &format!("the request head is larger than {MAX_HEAD_BYTES} bytes")));
            }
            Ok(httparse::Status::Partial) => {}
            Err(httparse::Error::TooManyHeaders) => return Err(Reply::text(431, "more than 64 request headers")),
            Err(e) => return Err(Reply::text(400, &format!("malformed request: {e}"))),
        }
    }
}

fn answer(request: &RequestHead, hosts: Option<&[String]>, handler: &Handler) -> (Reply, bool) {
    let head_only = request.method == "HEAD";
    if request.method != "GET" && !head_only {
        return (Reply::text(405, "only GET and HEAD are served").with("Allow", "GET, HEAD".into()), false);
    }
    if request.has_body {
        return (Reply::text(413, "requests to the viewer carry no body"), head_only);
    }
    if let Some(hosts) = hosts
        && !request.host.as_ref().is_some_and(|h| hosts.iter().any(|a| a.eq_ignore_ascii_case(h)))
    {
        return (
            Reply::text(403, "this viewer answers only requests addressed to it by its loopback address"),
            head_only,
        );
    }
    (handler(&request.url), head_only)
}

fn write_reply(stream: &mut TcpStream, reply: &Reply, head_only: bool) -> std::io::Result<()> {
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
    stream.write_all(head.as_bytes())?;
    if !head_only {
        stream.write_all(&reply.body)?;
    }
    stream.flush()
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
