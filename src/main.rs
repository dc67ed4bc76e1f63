use clap::Parser;

fn main() {
    let cli = stickslip::cli::Cli::parse();
    if let Err(e) = stickslip::app::execute(cli.command) {
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
