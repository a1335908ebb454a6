//! The `preston` binary: `serve` (default), `openapi`, `compute`, `backup`, `healthcheck`. Thin
//! by design.

use std::io::{ErrorKind, Read, Write};
use std::process::ExitCode;

use clap::builder::PossibleValuesParser;
use clap::{CommandFactory, FromArgMatches};
use preston::config::{Cli, Command};
use preston::http::{compute_json, openapi, ENDPOINTS};

fn main() -> ExitCode {
    // The endpoints `compute` takes are the endpoint table's: its help lists them and clap
    // refuses any other.
    let names = ENDPOINTS.iter().map(|e| e.name);
    let matches = Cli::command()
        .mut_subcommand("compute", |c| {
            // (`mut_arg` puts the argument last: FILE is put back after it.)
            c.mut_arg("endpoint", |a| {
                a.value_parser(PossibleValuesParser::new(names))
            })
            .mut_arg("file", |a| a)
        })
        .get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    match cli.command {
        Some(Command::Openapi) => output(&openapi::spec_json(), ExitCode::SUCCESS),
        Some(Command::Compute { endpoint, file }) => compute(&endpoint, &file, &cli.serve),
        Some(Command::Serve(args)) => serve(*args),
        Some(Command::Backup { file }) => backup(&file, &cli.serve),
        Some(Command::Healthcheck { listen, timeout_ms }) => {
            let addr = preston::healthcheck::target(listen);
            match preston::healthcheck::probe(addr, std::time::Duration::from_millis(timeout_ms)) {
                Ok(()) => ExitCode::SUCCESS,
                Err(why) => {
                    eprintln!("preston: unhealthy: {why}");
                    ExitCode::FAILURE
                }
            }
        }
        None => serve(cli.serve),
    }
}

fn serve(args: preston::config::ServeArgs) -> ExitCode {
    preston::memory::keep_freed_memory();
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

fn backup(file: &std::path::Path, args: &preston::config::ServeArgs) -> ExitCode {
    let copied = tokio::runtime::Runtime::new()
        .map_err(|e| e.to_string())
        .and_then(|runtime| {
            runtime.block_on(async {
                let store = preston::store::Store::open(&args.store_options()?)
                    .await
                    .map_err(|e| e.to_string())?;
                let copied = store.backup(file).await.map_err(|e| e.to_string());
                store.close().await;
                copied
            })
        });
    match copied {
        Ok(()) => {
            eprintln!("preston: the records are copied to {}", file.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("preston: backup failed: {e}");
            ExitCode::FAILURE
        }
    }
}

fn compute(endpoint: &str, file: &std::path::Path, args: &preston::config::ServeArgs) -> ExitCode {
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
        Ok(json) => output(&format!("{json}\n"), ExitCode::SUCCESS),
        Err(problem) => output(&format!("{}\n", problem.to_json()), ExitCode::from(2)),
    }
}

/// Writes `text` to standard output and exits with `code`. A reader that stopped reading
/// (`preston compute … | head`) is not an error; any other write failure is (exit 74).
fn output(text: &str, code: ExitCode) -> ExitCode {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => code,
        Err(e) if e.kind() == ErrorKind::BrokenPipe => code,
        Err(e) => {
            eprintln!("preston: cannot write the output: {e}");
            ExitCode::from(74)
        }
    }
}
