//! The links to a device: a serial port (USB CDC-ACM or a UART, through the `serialport` crate, no libudev), a
//! TCP socket (`tcp:HOST:PORT`: QEMU's serial port, ser2net), or a file or stdin replayed as if it arrived.
//!
//! [`Source`] opens connections and can open them again after a disconnect; [`Link`] is one open connection.
//! The recorder, the field-log read-out and the bring-up checks run over these traits, and their tests over fake
//! ports that fail and come back.

use std::io::{self, Read};
use std::net::TcpStream;
use std::sync::mpsc;
use std::time::Duration;

/// What one read from a link gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadOutcome {
    /// Bytes arrived (at least one).
    Data(usize),
    /// Nothing arrived within the link's timeout; try again.
    Idle,
    /// The source has ended for good (the end of a file or of stdin).
    End,
}

/// An open connection to a device.
pub trait Link {
    /// Read what has arrived, waiting at most the link's timeout.
    ///
    /// # Errors
    /// Any error means the connection is lost (unplugged device, reset port).
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome>;

    /// Send bytes to the device.
    ///
    /// # Errors
    /// The connection is lost, or the link cannot send (a file).
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;
}

/// Where links come from: a port that can be opened again after a disconnect.
pub trait Source {
    /// The link type.
    type Link: Link;

    /// What to call the source in messages (the port path, the file name, `stdin`).
    fn name(&self) -> String;

    /// Open a connection.
    ///
    /// # Errors
    /// The port cannot be opened (not there, busy, no permission).
    fn connect(&mut self) -> io::Result<Self::Link>;

    /// Whether a lost connection can come back (a port can; a file or stdin cannot).
    fn can_reconnect(&self) -> bool;

    /// Whether commands can be sent.
    fn can_send(&self) -> bool {
        self.can_reconnect()
    }
}

/// A serial port (USB CDC-ACM or a UART) through the `serialport` crate.
#[derive(Clone, Debug)]
pub struct SerialSource {
    /// The port, for example `/dev/ttyACM0` or `COM3`.
    pub path: String,
    /// Baud rate (ignored by USB CDC-ACM, used by a UART).
    pub baud: u32,
    /// How long one read waits for bytes.
    pub timeout: Duration,
}

/// An open serial port.
pub struct SerialLink(Box<dyn serialport::SerialPort>);

impl Link for SerialLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        // A tty that reads 0 bytes was hung up: the device is gone.
        stream_read(&mut self.0, buf, "the port was closed (device gone)")
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        stream_write(&mut self.0, bytes)
    }
}

/// A read from a byte stream with a timeout, as a link reads it: 0 bytes is the peer gone (`closed` says how),
/// a timeout or an interruption is idle.
fn stream_read(stream: &mut impl Read, buf: &mut [u8], closed: &str) -> io::Result<ReadOutcome> {
    match stream.read(buf) {
        Ok(0) => Err(io::Error::new(io::ErrorKind::UnexpectedEof, closed.to_string())),
        Ok(n) => Ok(ReadOutcome::Data(n)),
        Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => Ok(ReadOutcome::Idle),
        Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(ReadOutcome::Idle),
        Err(e) => Err(e),
    }
}

/// Write all of `bytes` to a byte stream and flush it.
fn stream_write(stream: &mut impl io::Write, bytes: &[u8]) -> io::Result<()> {
    stream.write_all(bytes)?;
    stream.flush()
}

impl Source for SerialSource {
    type Link = SerialLink;

    fn name(&self) -> String {
        self.path.clone()
    }

    fn connect(&mut self) -> io::Result<SerialLink> {
        // DTR on: the firmware sends frames only while the host holds DTR (Linux sets it on open; other systems
        // are told).
        let port = serialport::new(&self.path, self.baud)
            .timeout(self.timeout)
            .dtr_on_open(true)
            .open()
            .map_err(io::Error::from)?;
        Ok(SerialLink(port))
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

/// A file or stdin, read on a thread so that a stop request is seen even while nothing arrives.
pub struct ReaderSource {
    name: String,
    reader: Option<Box<dyn Read + Send>>,
    poll: Duration,
}

impl ReaderSource {
    /// Read `reader` (called `name` in messages), checking for a stop every `poll` while waiting.
    pub fn new(name: &str, reader: Box<dyn Read + Send>, poll: Duration) -> Self {
        ReaderSource { name: name.to_string(), reader: Some(reader), poll }
    }
}

/// The receiving end of a [`ReaderSource`]'s thread.
pub struct ReaderLink {
    rx: mpsc::Receiver<io::Result<Vec<u8>>>,
    pending: Vec<u8>,
    poll: Duration,
}

impl Link for ReaderLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        if self.pending.is_empty() {
            match self.rx.recv_timeout(self.poll) {
                Ok(Ok(bytes)) => self.pending = bytes,
                Ok(Err(e)) => return Err(e),
                Err(mpsc::RecvTimeoutError::Timeout) => return Ok(ReadOutcome::Idle),
                Err(mpsc::RecvTimeoutError::Disconnected) => return Ok(ReadOutcome::End),
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(ReadOutcome::Data(n))
    }

    fn write_all(&mut self, _bytes: &[u8]) -> io::Result<()> {
        Err(io::Error::new(io::ErrorKind::Unsupported, "cannot send commands to a file"))
    }
}

impl Source for ReaderSource {
    type Link = ReaderLink;

    fn name(&self) -> String {
        self.name.clone()
    }

    fn connect(&mut self) -> io::Result<ReaderLink> {
        let mut reader = self
            .reader
            .take()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotConnected, "the input was already read"))?;
        let (tx, rx) = mpsc::sync_channel(16);
        std::thread::spawn(move || {
            let mut buf = vec![0u8; 1 << 16];
            loop {
                match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => {
                        if tx.send(Ok(buf[..n].to_vec())).is_err() {
                            break;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
        });
        Ok(ReaderLink { rx, pending: Vec::new(), poll: self.poll })
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}

/// A TCP socket that carries the device's serial bytes: `tcp:HOST:PORT` (QEMU's `-serial tcp:...,server`, a
/// ser2net bridge).
#[derive(Clone, Debug)]
pub struct TcpSource {
    /// `HOST:PORT`.
    pub address: String,
    /// How long one read waits for bytes.
    pub timeout: Duration,
}

/// An open TCP connection.
pub struct TcpLink(TcpStream);

impl TcpLink {
    /// A link over a connection made elsewhere (a listener that the device's side connects to), reading with
    /// `timeout`.
    ///
    /// # Errors
    /// Setting the socket's options failed.
    pub fn from_stream(stream: TcpStream, timeout: Duration) -> io::Result<Self> {
        stream.set_read_timeout(Some(timeout))?;
        stream.set_nodelay(true)?;
        Ok(TcpLink(stream))
    }
}

impl Link for TcpLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        stream_read(&mut self.0, buf, "the connection was closed")
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        stream_write(&mut self.0, bytes)
    }
}

impl Source for TcpSource {
    type Link = TcpLink;

    fn name(&self) -> String {
        format!("tcp:{}", self.address)
    }

    fn connect(&mut self) -> io::Result<TcpLink> {
        TcpLink::from_stream(TcpStream::connect(&self.address)?, self.timeout)
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

/// A device port named as a user types it: `tcp:HOST:PORT`, or a serial port's path.
#[derive(Clone, Debug)]
pub enum PortSource {
    /// A serial port.
    Serial(SerialSource),
    /// A TCP socket.
    Tcp(TcpSource),
}

impl PortSource {
    /// The port `spec` names, reading with `timeout` (`baud` for a UART).
    pub fn parse(spec: &str, baud: u32, timeout: Duration) -> Self {
        match spec.strip_prefix("tcp:") {
            Some(address) => PortSource::Tcp(TcpSource { address: address.to_string(), timeout }),
            None => PortSource::Serial(SerialSource { path: spec.to_string(), baud, timeout }),
        }
    }
}

/// An open [`PortSource`] link.
pub enum PortLink {
    /// A serial port.
    Serial(SerialLink),
    /// A TCP socket.
    Tcp(TcpLink),
}

impl Link for PortLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        match self {
            PortLink::Serial(l) => l.read(buf),
            PortLink::Tcp(l) => l.read(buf),
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        match self {
            PortLink::Serial(l) => l.write_all(bytes),
            PortLink::Tcp(l) => l.write_all(bytes),
        }
    }
}

impl Source for PortSource {
    type Link = PortLink;

    fn name(&self) -> String {
        match self {
            PortSource::Serial(s) => s.name(),
            PortSource::Tcp(s) => s.name(),
        }
    }

    fn connect(&mut self) -> io::Result<PortLink> {
        match self {
            PortSource::Serial(s) => s.connect().map(PortLink::Serial),
            PortSource::Tcp(s) => s.connect().map(PortLink::Tcp),
        }
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;

    #[test]
    fn a_port_spec_names_tcp_or_serial() {
        let t = Duration::from_millis(10);
        assert!(
            matches!(PortSource::parse("tcp:127.0.0.1:5555", 0, t), PortSource::Tcp(s) if s.address == "127.0.0.1:5555")
        );
        assert!(
            matches!(PortSource::parse("/dev/ttyACM0", 9600, t), PortSource::Serial(s) if s.path == "/dev/ttyACM0" && s.baud == 9600)
        );
    }

    /// Bytes both ways over a TCP link; the peer closing it is a lost connection, and a new one can be opened.
    #[test]
    fn a_tcp_link_carries_bytes_both_ways_and_reports_a_close() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        let peer = std::thread::spawn(move || {
            for _ in 0..2 {
                let (mut s, _) = listener.accept().unwrap();
                let mut got = [0u8; 3];
                s.read_exact(&mut got).unwrap();
                io::Write::write_all(&mut s, &got.map(|b| b + 1)).unwrap();
            }
        });
        let mut src = PortSource::parse(&format!("tcp:{address}"), 0, Duration::from_millis(50));
        for _ in 0..2 {
            let mut link = src.connect().unwrap();
            link.write_all(&[1, 2, 3]).unwrap();
            let mut buf = [0u8; 8];
            let mut got = Vec::new();
            let closed = loop {
                match link.read(&mut buf) {
                    Ok(ReadOutcome::Data(n)) => got.extend_from_slice(&buf[..n]),
                    Ok(_) => {}
                    Err(e) => break e,
                }
            };
            assert_eq!(got, [2, 3, 4]);
            assert_eq!(closed.kind(), io::ErrorKind::UnexpectedEof);
        }
        peer.join().unwrap();
    }
}
