//! Lucid's viewer: a local web page that shows a model rendered by Lucid on this CPU, to fly
//! around, refocus and compare with the dataset's images ([`ViewServer::for_model`], which
//! `lucid view` serves); and the same page for a model while it trains ([`live`], which
//! `lucid train nerf|splat --view` serves).
//!
//! The server's connection threads parse requests and answer the page, its script, the
//! model's description and a run's progress themselves; requests that need the model wait in
//! a short queue for the thread that owns it. Everything the page sends and receives is in the
//! model's frame (a capture's normalised coordinates), as the dataset's cameras are once read.

mod answers;
#[cfg(test)]
mod fuzz;
pub mod live;
mod queue;
mod requests;
mod server;

use std::net::TcpListener;
use std::sync::mpsc::channel;
use std::sync::{Arc, Mutex};

use lucid_scene::scene_model::SceneModel;
use lucid_scene::{Dataset, PinholeCamera};
use serde_json::{Value, json};

use self::answers::{Reply, ViewedScene};
use self::queue::{Job, RenderQueue};
use self::requests::Route;
use self::server::Client;

const PAGE: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/viewer.js");

/// Renders waiting for a checkpoint's model thread; a request beyond them gets 503 (the page
/// keeps at most two in flight, so only several pages at once fill it; requests whose clients
/// have gone do not count).
const RENDER_QUEUE: usize = 4;

/// A listening viewer: its URL and the queue of requests that need the model.
pub struct ViewServer {
    /// `http://host:port/`.
    pub url: String,
    queue: Arc<RenderQueue>,
}

impl ViewServer {
    /// Listens on `host:port` and serves from connection threads: the page, `info`, and
    /// `status` where given (a training run's progress, updated by its owner); model requests
    /// wait in a queue of `queue` for [`Self::queue`]'s reader.
    pub(crate) fn start(
        host: &str,
        port: u16,
        info: Value,
        status: Option<Arc<Mutex<Value>>>,
        queue: usize,
    ) -> Result<Self, ViewError> {
        let address = format!("{host}:{port}");
        let listener = TcpListener::bind((host, port)).map_err(|source| ViewError::Listen { address, source })?;
        let addr = listener.local_addr()?;
        if !addr.ip().is_loopback() {
            tracing::warn!("serving on {addr}: every machine that reaches this address can view the model");
        }
        let queue = Arc::new(RenderQueue::new(queue));
        let jobs = queue.clone();
        let info = info.to_string();
        let handler = move |url: &str, client: &Client| handle(url, client, &info, status.as_deref(), &jobs);
        server::spawn(listener, server::loopback_hosts(addr), Arc::new(handler))?;
        let shown = if addr.ip().is_unspecified() { format!("127.0.0.1:{}", addr.port()) } else { addr.to_string() };
        Ok(Self { url: format!("http://{shown}/"), queue })
    }

    /// Listens on `host:port` for the page of `model` (named `name` on it), with `dataset`'s
    /// images to compare with where given.
    pub fn for_model(
        host: &str,
        port: u16,
        name: &str,
        model: &dyn SceneModel,
        dataset: Option<&Dataset>,
    ) -> Result<Self, ViewError> {
        Self::start(host, port, info(name, model, dataset, false), None, RENDER_QUEUE)
    }

    /// Answers the page's requests with renders of `model` on this thread, until the server is
    /// gone (never, short of the process ending).
    pub fn serve(&self, model: &dyn SceneModel, dataset: Option<&Dataset>) {
        let scene = ViewedScene { renderer: model, dataset };
        while let Some(job) = self.queue.next() {
            job.answer_from(&scene);
        }
    }
}

/// Why the viewer could not serve.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The address could not be listened on (a port in use, a host not of this machine).
    #[error("cannot listen on {address}: {source}")]
    Listen {
        /// `host:port`.
        address: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The listening socket failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Answers one URL on a connection thread: pages, the description and the progress at once,
/// the rest through the model thread's queue.
fn handle(url: &str, client: &Client, info: &str, status: Option<&Mutex<Value>>, jobs: &RenderQueue) -> Reply {
    let route = match requests::parse(url) {
        Ok(route) => route,
        Err(refusal) => return Reply::text(refusal.status, &refusal.reason),
    };
    let text = |content_type: &'static str, body: String| Reply {
        status: 200,
        content_type,
        body: body.into_bytes(),
        headers: vec![],
    };
    match route {
        Route::Page => text("text/html; charset=utf-8", PAGE.into()),
        Route::Script => text("text/javascript; charset=utf-8", SCRIPT.into()),
        Route::Info => text("application/json", info.into()),
        Route::Status => match status {
            Some(status) => text("application/json", status.lock().map(|s| s.to_string()).unwrap_or_default()),
            None => Reply::text(404, "not a training run (lucid train nerf|splat ... --view shows one)"),
        },
        route => {
            let (reply, answer) = channel();
            let client = match client.try_clone() {
                Ok(client) => client,
                Err(e) => return Reply::text(503, &format!("cannot serve this connection: {e}")),
            };
            match jobs.offer(Job::new(route, reply, client)) {
                // No reply: the client went and the job was dropped, or the model is gone.
                Ok(()) => answer.recv().unwrap_or_else(|_| Reply::text(503, "the model is no longer served")),
                Err(_) => Reply::text(503, "the renderer is busy; try again").with("Retry-After", "1".into()),
            }
        }
    }
}

/// What the page needs to know before its first render: the model's kind, how its training
/// cameras saw it, and the dataset's cameras (poses row-major, as requests send them).
fn info(name: &str, model: &dyn SceneModel, dataset: Option<&Dataset>, live: bool) -> Value {
    let view = model.view();
    let background = model.background();
    let cameras: Vec<Value> = dataset
        .map(|d| {
            d.splits
                .iter()
                .flat_map(|s| s.frames.iter().enumerate().map(move |(i, f)| (s.split, i, f)))
                .map(|(split, index, frame)| camera_json(split.name(), index, &frame.file_path, &frame.camera))
                .collect()
        })
        .unwrap_or_default();
    let mut info = view_fields(model, background);
    let more = json!({
        "checkpoint": name,
        "kind": model.kind(),
        "step": model.step(),
        "live": live,
        // How the model's frame maps back to the dataset's (a capture's normalisation), for
        // the camera paths the page saves: p_dataset = rotation · p / scale + centre.
        "to_dataset": view.frame.map(|n| json!({
            "rotation": glam::DMat3::from_quat(n.rotation.inverse()).transpose().to_cols_array(),
            "centre": n.centre.to_array(),
            "scale": n.scale,
        })),
        "dataset": dataset.map(|d| d.root.display().to_string()),
        "cameras": cameras,
    });
    if let (Some(info), Value::Object(more)) = (info.as_object_mut(), more) {
        info.extend(more);
    }
    info
}

/// How the model's training cameras saw it, for a page's first camera (shared with the web
/// export's `scene.json`): image size, vertical field of view, the scene's centre and the
/// cameras' distance from it, up, and the background.
pub fn view_fields(model: &dyn SceneModel, background: [f32; 3]) -> Value {
    let view = model.view();
    let fov_y = 2.0 * ((0.5 * view.fov_x).tan() * view.height as f32 / view.width as f32).atan();
    json!({
        "width": view.width,
        "height": view.height,
        "fov_y_degrees": fov_y.to_degrees(),
        "centre": model.centre().to_array(),
        "radius": view.radius,
        "up": [0.0, 0.0, 1.0],
        "background": background,
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
