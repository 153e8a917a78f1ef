//! The byte stream to the firmware: a serial port (a board), or a TCP socket (the QEMU
//! firmware's USART, `scripts/qemu-link`). Both with a read timeout, so a silent peer is an
//! error and never a hang.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use crate::client::ConsoleError;

/// A byte stream with a read timeout.
pub trait Link: Read + Write + Send {
    /// Sets how long a read may wait for a byte.
    fn set_timeout(&mut self, timeout: Duration) -> Result<(), ConsoleError>;
}

impl Link for TcpStream {
    fn set_timeout(&mut self, timeout: Duration) -> Result<(), ConsoleError> {
        self.set_read_timeout(Some(timeout))
            .map_err(|e| ConsoleError::Io(format!("socket: {e}")))
    }
}

/// A serial port (the board: 921 600 baud, 8N1).
pub struct Serial(Box<dyn serialport::SerialPort>);

impl Read for Serial {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl Write for Serial {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl Link for Serial {
    fn set_timeout(&mut self, timeout: Duration) -> Result<(), ConsoleError> {
        self.0
            .set_timeout(timeout)
            .map_err(|e| ConsoleError::Io(format!("serial port: {e}")))
    }
}

/// Opens the serial port `path` at `baud`, 8N1, no flow control.
pub fn serial(path: &str, baud: u32) -> Result<Box<dyn Link>, ConsoleError> {
    let port = serialport::new(path, baud)
        .timeout(Duration::from_millis(200))
        .open()
        .map_err(|e| ConsoleError::Io(format!("{path}: {e}")))?;
    Ok(Box::new(Serial(port)))
}

/// Connects to `addr` (`host:port`), within 5 s.
pub fn tcp(addr: &str) -> Result<Box<dyn Link>, ConsoleError> {
    use std::net::ToSocketAddrs;
    let target = addr
        .to_socket_addrs()
        .map_err(|e| ConsoleError::Io(format!("{addr}: {e}")))?
        .next()
        .ok_or_else(|| ConsoleError::Io(format!("{addr}: no address")))?;
    let stream = TcpStream::connect_timeout(&target, Duration::from_secs(5))
        .map_err(|e| ConsoleError::Io(format!("{addr}: {e}")))?;
    // Frames are small and interactive.
    let _ = stream.set_nodelay(true);
    Ok(Box::new(stream))
}
