//! The response side of [`super`]: every status the service sends, the
//! head every response carries, and the one-line error response.

/// Every status the service sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// 200.
    Ok,
    /// 400: malformed.
    BadRequest,
    /// 404: no such path.
    NotFound,
    /// 405: a method RFC 9110 defines, other than `GET` and `HEAD`.
    MethodNotAllowed,
    /// 408: the request did not arrive in time (the service's rule).
    RequestTimeout,
    /// 414: the request line is longer than [`super::LINE_MAX`].
    UriTooLong,
    /// 431: the headers are longer than [`super::HEADERS_MAX`].
    HeadersTooLarge,
    /// 501: a method nobody defined.
    NotImplemented,
    /// 505: not HTTP/1.0 or 1.1.
    VersionNotSupported,
    /// 503: every connection slot is busy (sent by a slot that has to
    /// turn a connection away).
    Unavailable,
    /// 405 for `/firmware`, which takes `PUT` and `DELETE` alone.
    PutOnly,
    /// 403: an update file whose signature does not verify.
    Forbidden,
    /// 409: an update that conflicts with the device's state (older than
    /// the running image, one marked already, another upload arriving).
    Conflict,
    /// 411: a `PUT` without a `Content-Length`.
    LengthRequired,
    /// 413: an update file larger than the update partition.
    ContentTooLarge,
    /// 422: an update file that is not one for this device.
    Unprocessable,
    /// 500: the flash refused an operation.
    InternalError,
}

impl Status {
    /// The status code.
    pub const fn code(self) -> u16 {
        match self {
            Status::Ok => 200,
            Status::BadRequest => 400,
            Status::NotFound => 404,
            Status::MethodNotAllowed => 405,
            Status::RequestTimeout => 408,
            Status::UriTooLong => 414,
            Status::HeadersTooLarge => 431,
            Status::NotImplemented => 501,
            Status::Unavailable => 503,
            Status::VersionNotSupported => 505,
            Status::PutOnly => 405,
            Status::Forbidden => 403,
            Status::Conflict => 409,
            Status::LengthRequired => 411,
            Status::ContentTooLarge => 413,
            Status::Unprocessable => 422,
            Status::InternalError => 500,
        }
    }

    /// The reason phrase.
    pub const fn reason(self) -> &'static str {
        match self {
            Status::Ok => "OK",
            Status::BadRequest => "Bad Request",
            Status::NotFound => "Not Found",
            Status::MethodNotAllowed => "Method Not Allowed",
            Status::RequestTimeout => "Request Timeout",
            Status::UriTooLong => "URI Too Long",
            Status::HeadersTooLarge => "Request Header Fields Too Large",
            Status::NotImplemented => "Not Implemented",
            Status::Unavailable => "Service Unavailable",
            Status::VersionNotSupported => "HTTP Version Not Supported",
            Status::PutOnly => "Method Not Allowed",
            Status::Forbidden => "Forbidden",
            Status::Conflict => "Conflict",
            Status::LengthRequired => "Length Required",
            Status::ContentTooLarge => "Content Too Large",
            Status::Unprocessable => "Unprocessable Content",
            Status::InternalError => "Internal Server Error",
        }
    }
}

/// Writes the response head for `status` with a body of `len` bytes of
/// `content_type`. Every response closes the connection and may not be
/// cached; the page may load nothing from anywhere (its CSS, script and
/// SVG are inline) and fetch only from the device itself.
pub fn head(out: &mut dyn crate::Out, status: Status, content_type: &str, len: usize, gzip: bool) {
    out.str("HTTP/1.1 ");
    out.u32(status.code().into());
    out.str(" ");
    out.str(status.reason());
    out.str("\r\nContent-Type: ");
    out.str(content_type);
    out.str("\r\nContent-Length: ");
    out.u64(len as u64);
    out.str("\r\nCache-Control: no-store\r\nConnection: close\r\nX-Content-Type-Options: nosniff\r\nContent-Security-Policy: default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; connect-src 'self'\r\n");
    match status {
        Status::MethodNotAllowed => out.str("Allow: GET, HEAD\r\n"),
        Status::PutOnly => out.str("Allow: PUT, DELETE\r\n"),
        _ => {}
    }
    if gzip {
        out.str("Content-Encoding: gzip\r\nVary: Accept-Encoding\r\n");
    }
    out.str("\r\n");
}

/// A whole error response: the head and a one-line text body.
pub fn error(out: &mut dyn crate::Out, status: Status) {
    let body_len = 3 + 1 + status.reason().len() + 1;
    head(out, status, "text/plain; charset=utf-8", body_len, false);
    out.u32(status.code().into());
    out.str(" ");
    out.str(status.reason());
    out.str("\n");
}
