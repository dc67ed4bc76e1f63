//! Standard output that never panics: `println!` panics when the pipe it writes to is closed
//! (`stickslip status OUT | head -1`) or the disk under a redirected output is full, which would
//! abort a sweep half-way. Everything the commands print goes through [`say!`](crate::say) and
//! [`stdout`]: a failed write is remembered, the command goes on (its files are its results),
//! and `main` reports the failure with exit code 1 once the command has finished.

use std::io::Write;
use std::sync::Mutex;

static FAILED: Mutex<Option<String>> = Mutex::new(None);

fn remember(e: &std::io::Error) {
    if let Ok(mut f) = FAILED.lock()
        && f.is_none()
    {
        *f = Some(e.to_string());
    }
}

/// The first error a write to standard output met, if any.
pub fn failure() -> Option<String> {
    FAILED.lock().ok().and_then(|f| f.clone())
}

/// Standard output, locked; a failed write is remembered ([`failure`]) and reported as done.
pub struct Stdout(std::io::StdoutLock<'static>);

/// Standard output for `write!`/`writeln!` (module docs).
pub fn stdout() -> Stdout {
    Stdout(std::io::stdout().lock())
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if failure().is_some() {
            return Ok(buf.len());
        }
        match self.0.write_all(buf) {
            Ok(()) => Ok(buf.len()),
            Err(e) => {
                remember(&e);
                Ok(buf.len())
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if let Err(e) = self.0.flush() {
            remember(&e);
        }
        Ok(())
    }
}

/// Writes formatted text to standard output ([`stdout`]) and flushes it.
pub fn print(args: std::fmt::Arguments) {
    let mut o = stdout();
    let _ = o.write_fmt(args);
    let _ = o.flush();
}

/// `println!` through [`stdout`](crate::console::stdout): never panics (module docs).
#[macro_export]
macro_rules! say {
    () => {
        $crate::console::print(format_args!("\n"))
    };
    ($($t:tt)*) => {
        $crate::console::print(format_args!("{}\n", format_args!($($t)*)))
    };
}

/// `eprintln!` that never panics: a message to standard error, dropped where that is closed.
#[macro_export]
macro_rules! note {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}
