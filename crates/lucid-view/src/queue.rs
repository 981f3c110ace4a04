//! The requests that wait for the thread that owns the model: a bounded queue from which
//! requests whose clients have gone are dropped, so that they neither fill it nor get rendered.

use std::collections::VecDeque;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc::Sender;
use std::sync::{Condvar, Mutex};

use super::answers::{Reply, ViewedScene};
use super::requests::Route;
use super::server::{Client, panic_message};

/// A request for the thread that owns the model, and where its reply goes.
pub struct Job {
    pub route: Route,
    reply: Sender<Reply>,
    client: Client,
}

impl Job {
    pub fn new(route: Route, reply: Sender<Reply>, client: Client) -> Self {
        Self { route, reply, client }
    }

    /// Whether nobody waits for the answer any more.
    pub fn abandoned(&self) -> bool {
        self.client.gone()
    }

    /// Answers the job from `scene`, unless its client goes first. A render that panics
    /// answers 500: the model's owner (a training run) goes on.
    pub fn answer_from(self, scene: &ViewedScene<'_>) {
        let answered = catch_unwind(AssertUnwindSafe(|| scene.answer(&self.route, &|| self.abandoned())));
        let reply = match answered {
            Ok(Some(reply)) => reply,
            Ok(None) => return,
            Err(panic) => {
                tracing::error!("a viewer request failed: {}", panic_message(&panic));
                Reply::text(500, &format!("the render failed: {}", panic_message(&panic)))
            }
        };
        // The connection may have closed while it waited: nothing to do then.
        let _ = self.reply.send(reply);
    }
}

/// Jobs waiting for the model, at most `capacity` of them whose clients are still there.
pub struct RenderQueue {
    jobs: Mutex<VecDeque<Job>>,
    ready: Condvar,
    capacity: usize,
}

impl RenderQueue {
    pub fn new(capacity: usize) -> Self {
        Self { jobs: Mutex::new(VecDeque::new()), ready: Condvar::new(), capacity }
    }

    /// Queues `job`, or hands it back when the queue is full of jobs someone waits for.
    pub fn offer(&self, job: Job) -> Result<(), Box<Job>> {
        let Ok(mut jobs) = self.jobs.lock() else { return Err(Box::new(job)) };
        jobs.retain(|j| !j.abandoned());
        if jobs.len() >= self.capacity {
            return Err(Box::new(job));
        }
        jobs.push_back(job);
        self.ready.notify_one();
        Ok(())
    }

    /// The next job someone waits for, waiting for one to come.
    pub fn next(&self) -> Option<Job> {
        let mut jobs = self.jobs.lock().ok()?;
        loop {
            while let Some(job) = jobs.pop_front() {
                if !job.abandoned() {
                    return Some(job);
                }
            }
            jobs = self.ready.wait(jobs).ok()?;
        }
    }

    /// The next job someone waits for, if one is queued.
    pub fn try_next(&self) -> Option<Job> {
        let mut jobs = self.jobs.lock().ok()?;
        std::iter::from_fn(|| jobs.pop_front()).find(|job| !job.abandoned())
    }
}

#[cfg(test)]
mod tests {
    use std::net::{TcpListener, TcpStream};
    use std::sync::mpsc::channel;

    use lucid_scene::evaluation::{RenderedView, ViewModel};
    use lucid_scene::{Intrinsics, PinholeCamera};

    use super::*;
    use crate::requests::{FrameFormat, ImageMode, ViewRequest};

    /// A model whose every render panics, as a bad request once made one.
    struct Panicking;

    impl ViewModel for Panicking {
        fn render_view(&self, _: &PinholeCamera, _: Option<(f32, f32)>, _: usize, _: u64) -> RenderedView {
            panic!("a render that fails")
        }

        fn background(&self) -> [f32; 3] {
            [0.0; 3]
        }
    }

    /// A job on a loopback connection, and the client's end of it.
    fn job() -> (Job, std::sync::mpsc::Receiver<Reply>, TcpStream) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let client = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let (served, _) = listener.accept().unwrap();
        served.set_nonblocking(true).unwrap();
        let camera = PinholeCamera::new(Intrinsics::from_fov_x(4, 4, 1.0), glam::Mat4::IDENTITY);
        let view = ViewRequest { camera, lens: None, lens_rays: 1, mode: ImageMode::Colour, format: FrameFormat::Png };
        let (reply, answer) = channel();
        (Job::new(Route::Render(view), reply, Client::for_tests(served)), answer, client)
    }

    #[test]
    fn a_render_that_panics_answers_500_and_the_owner_goes_on() {
        let (job, answer, _client) = job();
        job.answer_from(&ViewedScene { renderer: &Panicking, dataset: None });
        let reply = answer.recv().unwrap();
        assert_eq!(reply.status, 500);
        assert!(String::from_utf8_lossy(&reply.body).contains("a render that fails"));
    }

    #[test]
    fn jobs_whose_clients_went_neither_fill_the_queue_nor_get_rendered() {
        let queue = RenderQueue::new(2);
        let (a, _, client_a) = job();
        let (b, _, client_b) = job();
        assert!(queue.offer(a).is_ok() && queue.offer(b).is_ok());
        let (c, _, _client_c) = job();
        let c = *queue.offer(c).expect_err("full of two waiting clients");
        drop((client_a, client_b));
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert!(queue.offer(c).is_ok(), "the gone clients' jobs make room");
        let next = queue.try_next().expect("the live job");
        assert!(!next.abandoned());
        assert!(queue.try_next().is_none());
    }
}
