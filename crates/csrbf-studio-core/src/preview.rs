//! The live preview on a worker thread: the UI sends the document as it now
//! stands after each edit and keeps drawing; the worker takes only the
//! newest request (no queue of stale fits), runs [`Live`] on it and sends
//! back the deformed positions, their normals and what the diagnostics say.
//!
//! A drag step asks for positions only ([`Live::update_positions`]: one
//! solve per layer, no refactoring); an edit that changes a system (a start,
//! the radius, the kernel) or the end of a drag asks for the full update
//! with diagnostics.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use csrbf::Diagnostics;
use csrbf::glam::Vec3;

use crate::live::Live;
use crate::state::Document;

/// One result of the worker: the document of `generation`, deformed.
#[derive(Clone, Debug)]
pub struct PreviewFrame {
    /// The generation of the request this answers.
    pub generation: u64,
    /// Deformed positions.
    pub positions: Arc<Vec<Vec3>>,
    /// Their vertex normals (for a mesh over [`NORMALS_EVERY_STEP`]
    /// triangles, those of the last full update during a drag).
    pub normals: Arc<Vec<Vec3>>,
    /// What the diagnostics found (None for a drag step).
    pub diagnostics: Option<Arc<Diagnostics>>,
    /// When the edit folds: what would keep it from folding, as `csrbf
    /// deform` says it (the report's advice); "" otherwise.
    pub advice: String,
    /// Why the engine refused the document (the positions are then the last
    /// good ones).
    pub error: Option<String>,
    /// Time the worker spent on this request.
    pub took: Duration,
    /// Systems factored so far.
    pub factorisations: usize,
    /// Control vectors in use ([`Live::controls`]: handles' included).
    pub controls: usize,
}

enum Request {
    /// A new document (a mesh opened): a new [`Live`].
    Open(Box<Document>, u64),
    /// The same document with edits; `full`: diagnose too.
    Edit(Box<Document>, u64, bool),
}

/// The handle the UI keeps on the worker.
pub struct Preview {
    requests: Option<Sender<Request>>,
    frames: Receiver<PreviewFrame>,
    worker: Option<JoinHandle<()>>,
    generation: u64,
    latest: Option<PreviewFrame>,
    /// Whether the newest request is a drag step (positions only).
    step_sent: bool,
    /// The worker's time on the last drag step it answered.
    step_took: Option<Duration>,
    /// Set while the UI waits for an answer ([`Preview::catch_up`]): the
    /// worker then does not wake the window for another frame.
    waiting: Arc<AtomicBool>,
}

/// How long a frame may wait for the worker's answer to a drag step it
/// sent ([`Preview::catch_up`]): this, or more where frames are slow.
pub const CATCH_UP: Duration = Duration::from_millis(12);

/// The longest wait, however slow the frames.
pub const MAX_CATCH_UP: Duration = Duration::from_millis(50);

/// Whether a frame waits for the answer to request `sent` when the worker
/// has answered up to `answered` and took `step_took` on its last drag step:
/// not when it answered already, not when it is still on an earlier request
/// (a fit after a new start: the step waits behind it), not when its steps
/// take longer than `budget`.
fn worth_waiting(
    answered: Option<u64>,
    sent: u64,
    step_took: Option<Duration>,
    budget: Duration,
) -> bool {
    answered.is_some_and(|a| a + 1 == sent) && step_took.is_none_or(|t| t <= budget)
}

/// What a frame may wait for a drag step's answer when frames cost `frame`:
/// [`CATCH_UP`], or up to 60 % of a slow frame (a picture that waits 25 ms
/// for a 1M-vertex step shows the pointer's place one 70 ms frame sooner),
/// at most [`MAX_CATCH_UP`].
pub fn catch_up_budget(frame: Option<Duration>) -> Duration {
    frame
        .map_or(CATCH_UP, |f| f.mul_f64(0.6))
        .clamp(CATCH_UP, MAX_CATCH_UP)
}

impl Preview {
    /// Starts a worker on `doc`; `wake` is called after each frame it sends
    /// (the app asks for a repaint there).
    pub fn new(doc: &Document, wake: impl Fn() + Send + 'static) -> Preview {
        let (requests, inbox) = channel::<Request>();
        let (outbox, frames) = channel::<PreviewFrame>();
        let waiting = Arc::new(AtomicBool::new(false));
        let ui_waits = waiting.clone();
        // A frame the UI waits for is drawn by the frame waiting; a wake
        // would ask for one more (40-60 ms on a software rasteriser) that
        // the next pointer move waits behind. A frame sent just as the wait
        // gives up is drawn by the repaint the app asks while unsettled.
        let wake = move || {
            if !ui_waits.load(Ordering::Acquire) {
                wake();
            }
        };
        let worker = std::thread::Builder::new()
            .name("csrbf-preview".into())
            .spawn(move || work(inbox, outbox, wake))
            .ok();
        let mut p = Preview {
            requests: Some(requests),
            frames,
            worker,
            generation: 0,
            latest: None,
            step_sent: false,
            step_took: None,
            waiting,
        };
        p.open(doc);
        p
    }

    /// A new document, replacing the old one.
    pub fn open(&mut self, doc: &Document) -> u64 {
        self.generation += 1;
        self.step_sent = false;
        self.send(Request::Open(Box::new(doc.clone()), self.generation));
        self.generation
    }

    /// The document changed: refit what must be (`full`: and diagnose),
    /// superseding any request not yet started.
    pub fn edit(&mut self, doc: &Document, full: bool) -> u64 {
        self.generation += 1;
        self.step_sent = !full;
        self.send(Request::Edit(Box::new(doc.clone()), self.generation, full));
        self.generation
    }

    fn send(&mut self, r: Request) {
        if let Some(tx) = &self.requests
            && tx.send(r).is_err()
        {
            self.requests = None;
        }
    }

    /// Takes what the worker has sent since the last call; true if a newer
    /// frame arrived.
    pub fn poll(&mut self) -> bool {
        let mut got = false;
        while let Ok(f) = self.frames.try_recv() {
            self.take(f);
            got = true;
        }
        got
    }

    /// Keeps `f` as the latest frame; a drag step has no diagnostics of its
    /// own, so the last ones stay shown until the release brings new ones.
    fn take(&mut self, mut f: PreviewFrame) {
        if f.diagnostics.is_none() && f.error.is_none() {
            self.step_took = Some(f.took);
        }
        if f.diagnostics.is_none()
            && let Some(old) = &self.latest
        {
            f.diagnostics = old.diagnostics.clone();
        }
        self.latest = Some(f);
    }

    /// The newest frame received.
    pub fn latest(&self) -> Option<&PreviewFrame> {
        self.latest.as_ref()
    }

    /// The generation of the newest request sent.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Whether the newest frame answers the newest request.
    pub fn is_settled(&self) -> bool {
        self.latest
            .as_ref()
            .is_some_and(|f| f.generation == self.generation)
    }

    /// A frame that sent a drag step waits for its answer when the worker
    /// has answered every request before it and its last drag step took at
    /// most `budget` ([`catch_up_budget`]), so the
    /// frame shows the pointer's new place instead of the one before (a
    /// whole frame sooner: 40-60 ms on a software rasteriser). Waits at
    /// most `budget`; returns the time waited.
    pub fn catch_up(&mut self, budget: Duration) -> Duration {
        self.poll();
        let answered = self.latest.as_ref().map(|f| f.generation);
        if !self.step_sent || !worth_waiting(answered, self.generation, self.step_took, budget) {
            return Duration::ZERO;
        }
        let started = Instant::now();
        self.waiting.store(true, Ordering::Release);
        self.wait(budget);
        self.waiting.store(false, Ordering::Release);
        started.elapsed()
    }

    /// Waits (up to `limit`) until the newest request is answered; for tests
    /// and for saving what is shown.
    pub fn wait(&mut self, limit: Duration) -> bool {
        let end = Instant::now() + limit;
        loop {
            self.poll();
            if self.is_settled() {
                return true;
            }
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() || self.requests.is_none() {
                return false;
            }
            match self
                .frames
                .recv_timeout(left.min(Duration::from_millis(50)))
            {
                Ok(f) => self.take(f),
                Err(_) => continue,
            }
        }
    }
}

impl Drop for Preview {
    fn drop(&mut self) {
        self.requests = None;
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}

/// Above this many triangles, a drag step's frame keeps the last normals
/// (the app draws a stand-in then; see [`BIG_MESH_TRIANGLES`]).
pub const NORMALS_EVERY_STEP: usize = 200_000;

/// Above this many triangles the viewport draws one sample per pixel (on a
/// software rasteriser 4x costs more than it shows) and, while the model
/// moves, a lighter stand-in ([`csrbf_mesh::StandIn`]): the Picker's model
/// and the Composer's objects alike.
pub const BIG_MESH_TRIANGLES: usize = NORMALS_EVERY_STEP;

fn work(inbox: Receiver<Request>, outbox: Sender<PreviewFrame>, wake: impl Fn()) {
    // Fits run on all but one core: the window (and a software rasteriser
    // drawing it) keeps one, so a long refit does not stall the frames.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cores.saturating_sub(1).max(1))
        .thread_name(|k| format!("csrbf-fit-{k}"))
        .build()
        .ok();
    serve(inbox, outbox, wake, pool.as_ref());
}

fn serve(
    inbox: Receiver<Request>,
    outbox: Sender<PreviewFrame>,
    wake: impl Fn(),
    pool: Option<&rayon::ThreadPool>,
) {
    let mut live: Option<Live> = None;
    let mut normals = Vec::new();
    let mut last_normals: Option<Arc<Vec<Vec3>>> = None;
    while let Ok(first) = inbox.recv() {
        // The newest request wins; an open among the skipped ones still
        // counts (the edits after it are on the new mesh), and so does a
        // request for diagnostics.
        let mut open = None;
        let mut edit = None;
        let mut full = false;
        let mut next = Some(first);
        while let Some(r) = next {
            match r {
                Request::Open(doc, generation) => {
                    open = Some((doc, generation));
                    edit = None;
                    full = true;
                }
                Request::Edit(doc, generation, f) => {
                    full |= f;
                    edit = Some((doc, generation));
                }
            }
            next = match inbox.try_recv() {
                Ok(r) => Some(r),
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => return,
            };
        }
        let started = Instant::now();
        if let Some((doc, _)) = &open {
            live = Some(Live::without_picking(doc));
        }
        let Some((doc, generation)) = edit.or(open) else {
            continue;
        };
        let Some(l) = live.as_mut() else {
            continue;
        };
        let mut fit = || {
            if full {
                l.update(&doc)
            } else {
                l.update_positions(&doc)
            }
        };
        let result = match pool {
            Some(p) => p.install(fit),
            None => fit(),
        };
        let error = result.err().map(|e| {
            use std::error::Error as _;
            match e.source() {
                Some(s) => format!("layer {}: {s}", e.layer),
                None => e.to_string(),
            }
        });
        // A drag step on a big mesh is drawn by a stand-in with normals of
        // its own: the full normals (40 ms at 2M triangles) wait for the
        // release.
        if full || l.triangles().len() <= NORMALS_EVERY_STEP || last_normals.is_none() {
            csrbf_mesh::triangle_vertex_normals_into(l.positions(), l.triangles(), &mut normals);
            last_normals = Some(Arc::new(normals.clone()));
        }
        let frame = PreviewFrame {
            generation,
            positions: Arc::new(l.positions().to_vec()),
            normals: last_normals.clone().unwrap_or_default(),
            diagnostics: l.diagnostics().cloned().map(Arc::new),
            advice: l.report().map(|r| r.advice()).unwrap_or_default(),
            error,
            took: started.elapsed(),
            factorisations: l.factorisations(),
            controls: l.controls(),
        };
        if outbox.send(frame).is_err() {
            return;
        }
        wake();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Command, History};
    use csrbf::glam::DVec3;
    use std::path::PathBuf;

    /// A sphere with one control vector (a pin at its top), its preview and
    /// history.
    fn sphere_with_a_start() -> (Document, Preview, History) {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 24, 48);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.7);
        let preview = Preview::new(&doc, || {});
        let mut history = History::default();
        history
            .apply(&mut doc, Command::add(0, DVec3::Y, DVec3::Y))
            .expect("add");
        (doc, preview, history)
    }

    /// Drag step `k`: the start's destination k hundredths above it, sent.
    fn drag_step(history: &mut History, doc: &mut Document, preview: &mut Preview, k: usize) {
        history
            .apply(
                doc,
                Command::SetTarget {
                    layer: 0,
                    index: 0,
                    target: DVec3::Y * (1.0 + 0.01 * k as f64),
                },
            )
            .expect("drag");
        preview.edit(doc, false);
    }

    #[test]
    fn the_newest_edit_wins_and_matches_a_fresh_update() {
        let (mut doc, mut preview, mut history) = sphere_with_a_start();
        preview.edit(&doc, true);
        history.begin_drag();
        for k in 1..=40 {
            drag_step(&mut history, &mut doc, &mut preview, k);
        }
        history.end_drag();
        let last = preview.edit(&doc, true);
        assert!(preview.wait(Duration::from_secs(20)), "the worker answers");
        let frame = preview.latest().expect("a frame");
        assert_eq!(frame.generation, last);
        assert!(frame.error.is_none(), "{:?}", frame.error);
        assert!(frame.diagnostics.is_some(), "the last request was full");
        assert_eq!(frame.factorisations, 1, "one system for one start");

        let mut live = Live::new(&doc);
        live.update(&doc).expect("update");
        assert_eq!(&frame.positions[..], live.positions());
        let want = csrbf_mesh::triangle_vertex_normals(live.positions(), live.triangles());
        assert_eq!(&frame.normals[..], &want[..]);

        // A refused edit keeps the last good positions and says which layer.
        history
            .apply(&mut doc, Command::add(0, DVec3::Y, DVec3::Y * 2.0))
            .expect("a coincident start");
        preview.edit(&doc, true);
        assert!(preview.wait(Duration::from_secs(20)));
        let frame = preview.latest().expect("a frame");
        let error = frame.error.as_deref().expect("refused");
        assert!(error.starts_with("layer 0"), "{error}");
        assert_eq!(&frame.positions[..], live.positions());
    }

    #[test]
    fn a_frame_waits_only_for_a_worker_free_to_answer_in_time() {
        let ms = Duration::from_millis;
        assert!(worth_waiting(Some(4), 5, None, CATCH_UP), "the first step");
        assert!(worth_waiting(Some(4), 5, Some(ms(3)), CATCH_UP));
        assert!(
            !worth_waiting(Some(5), 5, Some(ms(3)), CATCH_UP),
            "answered"
        );
        assert!(
            !worth_waiting(Some(3), 5, Some(ms(3)), CATCH_UP),
            "on a fit"
        );
        assert!(!worth_waiting(None, 2, None, CATCH_UP), "on the first fit");
        assert!(
            !worth_waiting(Some(4), 5, Some(ms(13)), CATCH_UP),
            "slow steps"
        );
    }

    #[test]
    fn a_slow_frame_may_wait_longer_but_never_long() {
        let ms = Duration::from_millis;
        assert_eq!(catch_up_budget(None), CATCH_UP);
        assert_eq!(catch_up_budget(Some(ms(5))), CATCH_UP);
        assert_eq!(catch_up_budget(Some(ms(70))), ms(42));
        assert_eq!(catch_up_budget(Some(ms(500))), MAX_CATCH_UP);
    }

    #[test]
    fn a_frame_waits_for_a_quick_drag_step_only() {
        let (mut doc, mut preview, mut history) = sphere_with_a_start();
        // A full edit (a new start: a fit) is never waited for, nor a step
        // sent before the worker answered it (it is still fitting).
        preview.edit(&doc, true);
        assert_eq!(preview.catch_up(CATCH_UP), Duration::ZERO);
        assert!(preview.wait(Duration::from_secs(20)));
        history.begin_drag();
        let mut step =
            |preview: &mut Preview, k: usize| drag_step(&mut history, &mut doc, preview, k);
        // The first step has no time to go by: it is waited for, up to the
        // limit; so is every step after a quick one.
        for k in 1..=5 {
            step(&mut preview, k);
            let waited = preview.catch_up(CATCH_UP);
            assert!(
                preview.is_settled() || waited >= CATCH_UP,
                "step {k}: neither answered nor waited the limit ({waited:?})"
            );
            assert!(preview.wait(Duration::from_secs(20)));
        }
        // After a slow step, the next is drawn when it comes.
        preview.step_took = Some(CATCH_UP + Duration::from_millis(1));
        step(&mut preview, 6);
        assert_eq!(preview.catch_up(CATCH_UP), Duration::ZERO);
        // An answered request is not waited for.
        assert!(preview.wait(Duration::from_secs(20)));
        assert_eq!(preview.catch_up(CATCH_UP), Duration::ZERO);
    }
}
