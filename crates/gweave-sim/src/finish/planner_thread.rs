//! The windows of a transform's changes planned on a thread of their own.
//!
//! The measure of a transform's output (`measure.rs`) reads the output, parses it, counts
//! `stats`, compares it with the input (`diff.rs`) and gathers the changes' windows
//! (`delta.rs`) on one thread, beside the transform's. Planning a window (`window.rs`) costs
//! about 2 000 instructions a line, and a `mix` plans a window of some 50 lines every 70 lines
//! of its output: that is most of the measure's time. So the measure only reads each attempt
//! at a window, with the estimators' parse side ([`Readers`](super::window::Readers): the
//! modal state the sides end in depends on the lines, not on the plan, so it decides where the
//! window ends), and hands the jobs that reading made ([`WindowJobs`]) to the planner thread
//! here, which plans them on the two sides in every mode ([`Plans`]) as an estimator fed the
//! lines would: the same jobs in the same order (also the attempts whose sides did not agree:
//! they move the plan sides' clocks on), so each window's times are the same to the bit. The
//! lines are parsed once, on the measure's thread; the planner thread parses nothing. The
//! measure takes the planned windows back in the order it sent them and adds their times then,
//! in that order, so the sums it writes are the same to the bit too.
//!
//! Memory is bounded: [`WINDOWS_IN_FLIGHT`] windows wait at most (the measure waits when they
//! are that many), and the planned ones come back with their buffers, which the next windows
//! reuse. The thread ends when the measure drops its [`Planner`], whatever the reason (the
//! output ended, the measure failed or was stopped, or it unwinds): the planner then finishes
//! at most the window it is on, finds nobody to hand it to, and is joined.

use std::collections::VecDeque;
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

use super::delta::Unmeasured;
use super::window::{Plans, WindowJobs};

/// Windows handed to the planner and not yet planned, at most: enough to ride out a long
/// window on either side (a window is 50 lines or so, its cap 8 192), few enough that the
/// jobs held (a planned move or so a line) stay a few megabytes at worst.
const WINDOWS_IN_FLIGHT: usize = 16;

/// One attempt at timing a window, and what the planner made of it.
#[derive(Debug)]
pub(super) struct WindowJob {
    /// What its lines came to on both sides, read on the measure's thread.
    pub jobs: WindowJobs,
    /// In the first layer: the window's change counts in the first layer's time.
    pub first_layer: bool,
    /// The window's first change's output line.
    pub first_change: u64,
    /// Whether the two sides agree after it, as the parse side found: the window closes and
    /// its times count (else it grows and is timed again).
    pub closes: bool,
    /// Once planned: the output's side's time and the input's, in each mode, s; `None` if a
    /// plan side refused a job.
    pub times_s: Option<[[f64; 2]; 2]>,
}

/// The thread, while it runs.
struct Running {
    /// `None` once every job is sent.
    jobs: Option<SyncSender<WindowJob>>,
    planned: Receiver<WindowJob>,
    thread: JoinHandle<()>,
}

/// Where the windows are planned.
enum At {
    /// Nowhere yet: the thread starts at the first window (an unchanged output plans none).
    Idle(Plans),
    Thread(Running),
    /// On the measure's thread, as each is sent: where no thread can be started.
    Here {
        sides: Plans,
        refused: bool,
        planned: VecDeque<WindowJob>,
    },
    /// The thread is gone (it panicked, or every job is taken back).
    Ended,
}

/// The planner thread's end on the measure's side.
pub(super) struct Planner {
    at: At,
    /// Planned jobs taken back, their buffers to reuse.
    spare: Vec<WindowJob>,
}

impl Planner {
    pub(super) fn new(sides: Plans) -> Self {
        Planner { at: At::Idle(sides), spare: Vec::new() }
    }

    /// Planning on the caller's thread, each window as it is sent, as the measure did before
    /// the planner thread: what the thread's figures are checked against.
    #[cfg(test)]
    pub(super) fn plan_here(&mut self) {
        if let At::Idle(sides) = std::mem::replace(&mut self.at, At::Ended) {
            self.at = At::Here { sides, refused: false, planned: VecDeque::new() };
        }
    }

    /// A job for a window, its first change at output line `first_change` (in the first
    /// layer: `first_layer`), its jobs to be read into.
    pub(super) fn job(&mut self, first_layer: bool, first_change: u64) -> WindowJob {
        let jobs = self.spare.pop().map(|job| job.jobs).unwrap_or_default();
        WindowJob { jobs, first_layer, first_change, closes: false, times_s: None }
    }

    /// Hands `job` to the planner thread (started now if it is the first), waiting while
    /// [`WINDOWS_IN_FLIGHT`] wait already.
    pub(super) fn send(&mut self, mut job: WindowJob) -> Result<(), Unmeasured> {
        if let At::Idle(_) = self.at {
            self.start();
        }
        match &mut self.at {
            At::Thread(Running { jobs: Some(jobs), .. }) => {
                if jobs.send(job).is_err() {
                    // The thread is gone: it panicked (it ends only when the measure hangs up).
                    self.join();
                    return Err(Unmeasured::NoPlanner);
                }
                Ok(())
            }
            At::Here { sides, refused, planned } => {
                plan_one(sides, &mut job, refused);
                planned.push_back(job);
                Ok(())
            }
            _ => Err(Unmeasured::NoPlanner),
        }
    }

    /// Starts the thread, or plans here if it cannot be started.
    fn start(&mut self) {
        let At::Idle(sides) = std::mem::replace(&mut self.at, At::Ended) else { return };
        // Kept in case no thread can be started (the closure goes with a failed spawn).
        let kept = sides.clone();
        let (jobs, queued) = mpsc::sync_channel(WINDOWS_IN_FLIGHT);
        let (done, planned) = mpsc::channel();
        self.at = match std::thread::Builder::new()
            .name("gweave-windows".into())
            .spawn(move || plan(sides, queued, done))
        {
            Ok(thread) => At::Thread(Running { jobs: Some(jobs), planned, thread }),
            Err(_) => At::Here { sides: kept, refused: false, planned: VecDeque::new() },
        };
    }

    /// The next job planned, in the order they were sent, if one is ready.
    pub(super) fn planned(&mut self) -> Option<WindowJob> {
        match &mut self.at {
            At::Thread(running) => running.planned.try_recv().ok(),
            At::Here { planned, .. } => planned.pop_front(),
            _ => None,
        }
    }

    /// The next job planned, waiting for it, once every job is sent; `None` when all are
    /// taken back (the thread is then joined).
    pub(super) fn wait(&mut self) -> Option<WindowJob> {
        let At::Thread(running) = &mut self.at else { return self.planned() };
        // No more jobs: the thread ends after the last.
        running.jobs = None;
        match running.planned.recv() {
            Ok(job) => Some(job),
            Err(_) => {
                self.join();
                None
            }
        }
    }

    /// Keeps a planned job's buffers for the next.
    pub(super) fn recycle(&mut self, job: WindowJob) {
        self.spare.push(job);
    }

    /// Stops the thread: it finishes the window it is on, finds the measure gone and ends.
    fn join(&mut self) {
        if let At::Thread(Running { jobs, planned, thread }) = std::mem::replace(&mut self.at, At::Ended) {
            drop((jobs, planned));
            if let Err(panic) = thread.join() {
                // Its panic goes on on the measure's thread, as it would have when the windows
                // were planned there (unless that one unwinds already).
                if !std::thread::panicking() {
                    std::panic::resume_unwind(panic);
                }
            }
        }
    }
}

impl Drop for Planner {
    fn drop(&mut self) {
        self.join();
    }
}

/// The planner thread: plans each job on `sides`, in order, and hands it back.
fn plan(mut sides: Plans, jobs: Receiver<WindowJob>, planned: Sender<WindowJob>) {
    let mut refused = false;
    for mut job in jobs {
        plan_one(&mut sides, &mut job, &mut refused);
        if planned.send(job).is_err() {
            return;
        }
    }
}

/// Plans `job` on `sides`, unless a line was `refused` already: the estimators are then
/// where it left them, and the measure gives up on the windows at that job.
fn plan_one(sides: &mut Plans, job: &mut WindowJob, refused: &mut bool) {
    job.times_s = match refused {
        true => None,
        false => sides.time(&job.jobs).ok(),
    };
    *refused = job.times_s.is_none();
}
