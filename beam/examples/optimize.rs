//! Runs the placement optimization without the simulator's CLI:
//! `cargo run --release -p flexarm-beam --example optimize -- [config.toml] [out_dir]`
//! (default out_dir `optimize-out`).

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let config = args
        .first()
        .filter(|s| !s.is_empty())
        .map(std::path::PathBuf::from);
    let out = args.get(1).map_or_else(
        || std::path::PathBuf::from("optimize-out"),
        std::path::PathBuf::from,
    );
    match flexarm_beam::cli::run_optimize(config.as_deref(), &out, true) {
        Ok(s) => println!("{s}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
