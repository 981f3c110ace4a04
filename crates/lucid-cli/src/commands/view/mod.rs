//! `lucid view CHECKPOINT [--dataset DIR] [--port 7007] [--host 127.0.0.1]`: a local web page
//! that shows the model rendered by Lucid on this CPU, to fly around, refocus and compare with
//! the dataset's images.
//!
//! One thread owns the model and renders one request at a time from a short queue; the
//! server's connection threads parse requests and answer the page, its script and the model's
//! description themselves. Everything the page sends and receives is in the model's frame
//! (a capture's normalised coordinates), as the dataset's cameras are once read.

mod answers;
mod requests;
mod server;

use std::net::TcpListener;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, channel, sync_channel};

use anyhow::Context;
use lucid_scene::{Dataset, PinholeCamera};
use serde_json::{Value, json};

use self::answers::{Reply, ViewedScene};
use self::requests::Route;
use crate::cli::ViewArgs;
use crate::loaded_model::LoadedModel;

const PAGE: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/viewer.js");

/// Renders waiting for the model thread; a request beyond them gets 503 (the page keeps one
/// in flight, so only several pages at once fill it).
const RENDER_QUEUE: usize = 4;

/// A request for the model thread, and where its reply goes.
struct Job {
    route: Route,
    reply: std::sync::mpsc::Sender<Reply>,
}

pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let loaded = LoadedModel::load(&args.checkpoint)?;
    let dataset = args
        .dataset
        .as_ref()
        .map(|dir| {
            Dataset::open_with(dir, &args.data.options()).with_context(|| format!("reading dataset {}", dir.display()))
        })
        .transpose()?;
    let info = Arc::new(info(&args, &loaded, dataset.as_ref()).to_string());
    let listener = TcpListener::bind((args.host.as_str(), args.port))
        .with_context(|| format!("cannot listen on {}:{}", args.host, args.port))?;
    let addr = listener.local_addr()?;
    if !addr.ip().is_loopback() {
        tracing::warn!("serving on {addr}: every machine that reaches this address can view the model");
    }
    let (jobs, queue) = sync_channel::<Job>(RENDER_QUEUE);
    let handler = move |url: &str| handle(url, &info, &jobs);
    server::spawn(listener, server::loopback_hosts(addr), Arc::new(handler))?;
    let shown = if addr.ip().is_unspecified() { format!("127.0.0.1:{}", addr.port()) } else { addr.to_string() };
    println!("lucid view: http://{shown}/  ({} model, step {}; Ctrl-C stops)", kind(&loaded), loaded.step());
    use std::io::Write;
    std::io::stdout().flush()?;
    loaded.with_renderer(|renderer| serve_renders(&ViewedScene { renderer, dataset: dataset.as_ref() }, queue));
    Ok(())
}

/// The model thread: answers queued requests in order until the server is gone.
fn serve_renders(scene: &ViewedScene, queue: Receiver<Job>) {
    for job in queue {
        let reply = scene.answer(&job.route);
        // The connection may have closed while it waited.
        let _ = job.reply.send(reply);
    }
}

/// Answers one URL on a connection thread: pages and the description at once, the rest
/// through the model thread's queue.
fn handle(url: &str, info: &str, jobs: &SyncSender<Job>) -> Reply {
    let route = match requests::parse(url) {
        Ok(route) => route,
        Err(refusal) => return Reply::text(refusal.status, &refusal.reason),
    };
    let text = |content_type: &'static str, body: &str| Reply {
        status: 200,
        content_type,
        body: body.as_bytes().to_vec(),
        headers: vec![],
    };
    match route {
        Route::Page => text("text/html; charset=utf-8", PAGE),
        Route::Script => text("text/javascript; charset=utf-8", SCRIPT),
        Route::Info => text("application/json", info),
        route => {
            let (reply, answer) = channel();
            match jobs.try_send(Job { route, reply }) {
                Ok(()) => answer.recv().unwrap_or_else(|_| Reply::text(500, "the renderer stopped")),
                Err(TrySendError::Full(_)) => Reply::text(503, &format!("{RENDER_QUEUE} renders are already waiting"))
                    .with("Retry-After", "1".into()),
                Err(TrySendError::Disconnected(_)) => Reply::text(500, "the renderer stopped"),
            }
        }
    }
}

fn kind(loaded: &LoadedModel) -> &'static str {
    match loaded {
        LoadedModel::Nerf(_) => "nerf",
        LoadedModel::Splat(_) => "splat",
    }
}

/// What the page needs to know before its first render: the model's kind, how its training
/// cameras saw it, and the dataset's cameras (poses row-major, as requests send them).
fn info(args: &ViewArgs, loaded: &LoadedModel, dataset: Option<&Dataset>) -> Value {
    let view = loaded.view();
    let fov_y = 2.0 * ((0.5 * view.fov_x).tan() * view.height as f32 / view.width as f32).atan();
    let background = loaded.with_renderer(|r| r.background());
    let cameras: Vec<Value> = dataset
        .map(|d| {
            d.splits
                .iter()
                .flat_map(|s| s.frames.iter().enumerate().map(move |(i, f)| (s.split, i, f)))
                .map(|(split, index, frame)| camera_json(split.name(), index, &frame.file_path, &frame.camera))
                .collect()
        })
        .unwrap_or_default();
    json!({
        "checkpoint": args.checkpoint.display().to_string(),
        "kind": kind(loaded),
        "step": loaded.step(),
        "width": view.width,
        "height": view.height,
        "fov_y_degrees": fov_y.to_degrees(),
        "centre": loaded.centre().to_array(),
        "radius": view.radius,
        "up": [0.0, 0.0, 1.0],
        "background": background,
        // How the model's frame maps back to the dataset's (a capture's normalisation), for
        // the camera paths the page saves: p_dataset = rotation · p / scale + centre.
        "to_dataset": view.frame.map(|n| json!({
            "rotation": glam::DMat3::from_quat(n.rotation.inverse()).transpose().to_cols_array(),
            "centre": n.centre.to_array(),
            "scale": n.scale,
        })),
        "dataset": dataset.map(|d| d.root.display().to_string()),
        "cameras": cameras,
    })
}

fn camera_json(split: &str, index: usize, name: &str, camera: &PinholeCamera) -> Value {
    let k = camera.intrinsics;
    json!({
        "split": split,
        "index": index,
        "name": name,
        "c2w": camera.camera_to_world.transpose().to_cols_array(),
        "fov_y_degrees": k.fov_y().to_degrees(),
        "width": k.width,
        "height": k.height,
    })
}
