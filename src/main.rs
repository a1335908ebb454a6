//! The `preston` binary: `serve` (default), `openapi`, `compute`. Thin by design.

use std::io::Read;
use std::process::ExitCode;

use clap::Parser;
use preston::config::{Cli, Command};
use preston::http::{compute_json, openapi, ENDPOINTS};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Openapi) => {
            print!("{}", openapi::spec_json());
            ExitCode::SUCCESS
        }
        Some(Command::Compute { endpoint, file }) => compute(&endpoint, &file, &cli.serve),
        Some(Command::Serve(args)) => serve(args),
        None => serve(cli.serve),
    }
}

fn serve(args: preston::config::ServeArgs) -> ExitCode {
    preston::telemetry::init(args.log_format);
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("preston: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(preston::server::run(args)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("preston: {e}");
            ExitCode::FAILURE
        }
    }
}

fn compute(endpoint: &str, file: &std::path::Path, args: &preston::config::ServeArgs) -> ExitCode {
    if !ENDPOINTS.iter().any(|e| e.name == endpoint) {
        let names: Vec<&str> = ENDPOINTS.iter().map(|e| e.name).collect();
        eprintln!(
            "preston: unknown endpoint `{endpoint}`; one of: {}",
            names.join(", ")
        );
        return ExitCode::from(64);
    }
    let mut body = Vec::new();
    let read = if file.as_os_str() == "-" {
        std::io::stdin().read_to_end(&mut body).map(|_| ())
    } else {
        std::fs::read(file).map(|b| body = b)
    };
    if let Err(e) = read {
        eprintln!("preston: cannot read {}: {e}", file.display());
        return ExitCode::from(66);
    }
    match compute_json(endpoint, &body, &args.limits()) {
        Ok(json) => {
            println!("{json}");
            ExitCode::SUCCESS
        }
        Err(problem) => {
            println!("{}", problem.to_json());
            ExitCode::from(2)
        }
    }
}
