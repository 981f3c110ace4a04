//! `lucid view CHECKPOINT [--dataset DIR] [--port 7007] [--host 127.0.0.1]`: serves the
//! viewer's page ([`lucid_view`]) of a model, rendered by Lucid on this CPU.

use anyhow::Context;
use lucid_scene::Dataset;
use lucid_view::ViewServer;

use crate::cli::ViewArgs;

pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let model = lucid_session::registry::open(&args.checkpoint)?;
    let dataset = args
        .dataset
        .as_ref()
        .map(|dir| {
            Dataset::open_with(dir, &args.data.options()).with_context(|| format!("reading dataset {}", dir.display()))
        })
        .transpose()?;
    let name = args.checkpoint.display().to_string();
    let server = ViewServer::for_model(&args.host, args.port, &name, &*model, dataset.as_ref())?;
    println!("lucid view: {}  ({} model, step {}; Ctrl-C stops)", server.url, model.kind(), model.step());
    use std::io::Write;
    std::io::stdout().flush()?;
    server.serve(&*model, dataset.as_ref());
    Ok(())
}
