//! Files on the host, over semihosting (paths relative to QEMU's working directory).

use semihosting::fs::File;
use semihosting::io::{Read, Write};

/// Longest path, bytes.
const MAX_PATH: usize = 512;

/// A semihosting call that failed, with the host's errno where it gave one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct IoError {
    /// The host's errno, or -1.
    pub errno: i32,
}

impl From<semihosting::io::Error> for IoError {
    fn from(e: semihosting::io::Error) -> Self {
        IoError {
            errno: e.raw_os_error().unwrap_or(-1),
        }
    }
}

/// A path as the C string semihosting takes; `None` when it is too long or holds a NUL.
fn c_path(path: &str) -> Option<heapless::CString<MAX_PATH>> {
    let mut c = heapless::CString::new();
    c.extend_from_bytes(path.as_bytes()).ok()?;
    Some(c)
}

/// Opens `path` for reading.
pub fn open(path: &str) -> Result<InputFile, IoError> {
    let path = c_path(path).ok_or(IoError { errno: -1 })?;
    Ok(InputFile(File::open(path.as_c_str())?))
}

/// Creates (or truncates) `path` for writing.
pub fn create(path: &str) -> Result<OutputFile, IoError> {
    let path = c_path(path).ok_or(IoError { errno: -1 })?;
    Ok(OutputFile(File::create(path.as_c_str())?))
}

/// A host file read through semihosting.
pub struct InputFile(File);

impl imade_pack::Source for InputFile {
    type Error = IoError;
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), IoError> {
        Ok(self.0.read_exact(buf)?)
    }
}

/// A host file written through semihosting.
pub struct OutputFile(File);

impl OutputFile {
    /// Writes `line` and a line end.
    pub fn write_line(&mut self, line: &str) -> Result<(), IoError> {
        self.0.write_all(line.as_bytes())?;
        Ok(self.0.write_all(b"\n")?)
    }
}

/// The program's arguments, read into a buffer of [`MAX_PATH`] bytes.
pub struct Args(semihosting::experimental::env::Args<MAX_PATH>);

impl Args {
    /// Reads the arguments given in QEMU's `-semihosting-config arg=...`.
    pub fn get() -> Result<Self, IoError> {
        Ok(Args(semihosting::experimental::env::args::<MAX_PATH>()?))
    }

    /// The arguments after the program name, in order. The underlying cursor is shared, so
    /// the arguments can be walked once.
    pub fn iter(&self) -> impl Iterator<Item = &str> {
        (&self.0).skip(1).map_while(Result::ok)
    }
}
