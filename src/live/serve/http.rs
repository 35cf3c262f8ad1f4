//! The HTTP/1.1 the page needs, over std's TCP and `httparse`, with the limits a server on a
//! shared machine must have: a request's head is at most [`MAX_HEAD`] bytes in at most
//! [`MAX_HEADERS`] lines, its body at most what the route allows (by `Content-Length`), and the
//! whole request must arrive within [`REQUEST_TIME`] (a client that trickles bytes gets a 408),
//! the response within [`RESPONSE_TIME`]. One request per connection (`Connection: close`).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// Largest request head (request line and headers).
pub const MAX_HEAD: usize = 16 * 1024;
/// Most header lines in a request.
pub const MAX_HEADERS: usize = 32;
/// Longest a client may take to send its whole request.
pub const REQUEST_TIME: Duration = Duration::from_secs(5);
/// Longest a client may take to accept a response.
pub const RESPONSE_TIME: Duration = Duration::from_secs(10);

/// A request as read.
pub struct Request {
    pub method: String,
    pub url: String,
    headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Request {
    /// The value of the header `name` (case-insensitive), if present.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }
}

/// Why no request could be read: the client went away (nothing to answer), or a status to
/// answer with.
pub enum ReadError {
    Gone,
    Status(u16, &'static str),
}

/// Reads what the client sends next into `buf`, waiting until the deadline at most.
fn read_some(
    stream: &mut TcpStream,
    buf: &mut Vec<u8>,
    deadline: Instant,
) -> Result<usize, ReadError> {
    let left = deadline.saturating_duration_since(Instant::now());
    if left.is_zero() {
        return Err(ReadError::Status(
            408,
            "the request took too long to arrive",
        ));
    }
    stream
        .set_read_timeout(Some(left))
        .map_err(|_| ReadError::Gone)?;
    let mut chunk = [0u8; 4096];
    match stream.read(&mut chunk) {
        Ok(0) => Err(ReadError::Gone),
        Ok(n) => {
            buf.extend_from_slice(&chunk[..n]);
            Ok(n)
        }
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ) =>
        {
            Err(ReadError::Status(
                408,
                "the request took too long to arrive",
            ))
        }
        Err(_) => Err(ReadError::Gone),
    }
}

/// Reads one request whose body may be at most `max_body` bytes.
pub fn read_request(stream: &mut TcpStream, max_body: usize) -> Result<Request, ReadError> {
    let deadline = Instant::now() + REQUEST_TIME;
    let mut buf = Vec::with_capacity(1024);
    // The head, up to its blank line.
    let head_len = loop {
        if let Some(end) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break end + 4;
        }
        if buf.len() > MAX_HEAD {
            return Err(ReadError::Status(431, "request head too large"));
        }
        read_some(stream, &mut buf, deadline)?;
    };
    if head_len > MAX_HEAD {
        return Err(ReadError::Status(431, "request head too large"));
    }
    let mut slots = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut parsed = httparse::Request::new(&mut slots);
    match parsed.parse(&buf[..head_len]) {
        Ok(httparse::Status::Complete(_)) => {}
        Err(httparse::Error::TooManyHeaders) => {
            return Err(ReadError::Status(431, "too many request headers"))
        }
        _ => return Err(ReadError::Status(400, "malformed request")),
    }
    let method = parsed.method.unwrap_or("").to_string();
    let url = parsed.path.unwrap_or("").to_string();
    let headers: Vec<(String, String)> = parsed
        .headers
        .iter()
        .map(|h| {
            (
                h.name.to_string(),
                String::from_utf8_lossy(h.value).trim().to_string(),
            )
        })
        .collect();
    let mut request = Request {
        method,
        url,
        headers,
        body: Vec::new(),
    };
    if request.header("Transfer-Encoding").is_some() {
        return Err(ReadError::Status(
            411,
            "send the body with a Content-Length",
        ));
    }
    let length = match request.header("Content-Length") {
        None => 0,
        Some(v) => v
            .parse::<usize>()
            .map_err(|_| ReadError::Status(400, "bad Content-Length"))?,
    };
    if length > max_body {
        return Err(ReadError::Status(413, "request body too large"));
    }
    // The body: what came with the head, then the rest.
    let mut body = buf.split_off(head_len);
    while body.len() < length {
        read_some(stream, &mut body, deadline)?;
    }
    body.truncate(length);
    request.body = body;
    Ok(request)
}

/// The reason phrase of the statuses raylab sends.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        411 => "Length Required",
        413 => "Content Too Large",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "",
    }
}

/// Writes a response and closes the connection; a client that went away or does not read
/// within [`RESPONSE_TIME`] only loses its response.
pub fn respond(
    stream: &mut TcpStream,
    status: u16,
    headers: &[(&str, &str)],
    body: &[u8],
    head_only: bool,
) {
    let mut head = format!(
        "HTTP/1.1 {status} {}\r\nContent-Length: {}\r\nConnection: close\r\n",
        reason(status),
        body.len()
    );
    for (name, value) in headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str("\r\n");
    let _ = stream.set_write_timeout(Some(RESPONSE_TIME));
    if stream.write_all(head.as_bytes()).is_ok() && !head_only {
        let _ = stream.write_all(body);
    }
    let _ = stream.flush();
    let _ = stream.shutdown(std::net::Shutdown::Write);
}
