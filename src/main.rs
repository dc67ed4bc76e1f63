use clap::Parser;
use std::io::Write;

fn main() {
    let cli = stickslip::cli::Cli::parse();
    let result = stickslip::app::execute(cli.command);
    // What went wrong, on standard error (whose own failure has nowhere left to go).
    let code = match (&result, stickslip::console::failure()) {
        (Err(e), _) => {
            let _ = writeln!(std::io::stderr(), "error: {e}");
            e.exit_code()
        }
        (Ok(()), Some(e)) => {
            let _ = writeln!(
                std::io::stderr(),
                "error: standard output: {e} (the command's files were written; its report was not)"
            );
            1
        }
        (Ok(()), None) => 0,
    };
    std::process::exit(code);
}
