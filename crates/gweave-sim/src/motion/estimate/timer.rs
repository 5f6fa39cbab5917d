//! The estimator as the engine's [`LineTimer`]: a raster job (`gweave::gen::raster_job`) is
//! timed by this planner while its G-code streams out. The engine sits below the simulator and
//! cannot name it, so the job takes the planner through that trait.

use gweave::gen::raster_job::{BoxError, LineTimer};

use super::Estimator;
use crate::motion::limits::MotionProfile;

impl LineTimer for Estimator {
    fn line(&mut self, line: &[u8]) -> Result<(), BoxError> {
        Ok(Estimator::line(self, line)?)
    }

    fn total_s(self: Box<Self>) -> f64 {
        self.finish().total_s
    }
}

impl Estimator {
    /// The planner a raster job is timed with: Marlin's defaults (3000 mm/s², junction
    /// deviation 0.013 mm, every `M400` a full stop), as `JobReport::time` documents. Pass it
    /// to `Job::run`.
    pub fn line_timer() -> Result<Box<dyn LineTimer>, BoxError> {
        Estimator::line_timer_on(&MotionProfile::default())
    }

    /// The planner of a raster job written for a machine (`--machine`): the machine's own
    /// motion, so the job's time is the one `gweave sim` gives on that machine (a binder jet's
    /// pistons, its accelerations), not Marlin's defaults.
    pub fn line_timer_on(motion: &MotionProfile) -> Result<Box<dyn LineTimer>, BoxError> {
        Ok(Box::new(Estimator::new(motion)?))
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use gweave::gen::raster_job::Setup;
    use gweave::Quiet;
    use gweave::RasterOptions;
    use gweave::Target;

    use super::*;

    #[test]
    fn streamed_estimate_equals_estimating_the_written_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("badge.gcode");
        let layers = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster/layers");
        let options = RasterOptions { flip_y: true, density: 2, ..RasterOptions::default() };
        let rep = Setup::new(vec![layers.clone()], options.clone())
            .job()
            .unwrap()
            .run(&Target::File(out.clone()), &mut Quiet, Estimator::line_timer)
            .unwrap();
        let whole = crate::estimate(std::fs::File::open(&out).unwrap(), &MotionProfile::default()).unwrap();
        assert_eq!(rep.time.method, "planner");
        assert_eq!(rep.time.motion_s, whole.total_s);
        // The planner's time exceeds the feed-rate bound: every column starts and stops.
        let fast = Setup::new(vec![layers], RasterOptions { fast_estimate: true, ..options }).job().unwrap();
        let rep_fast = fast.run(&Target::File(out), &mut Quiet, Estimator::line_timer).unwrap();
        assert_eq!(rep_fast.time.method, "feed");
        assert!(rep.time.total_s > rep_fast.time.total_s, "{:?} {:?}", rep.time, rep_fast.time);
    }

    #[test]
    fn the_timer_times_lines_as_the_estimator_does() {
        let text = b"G1 X10 F600\nM400\nG1 X20\nG1 Y5\nM400\n";
        let mut timer = Estimator::line_timer().unwrap();
        for line in text.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
            timer.line(line).unwrap();
        }
        let whole = crate::estimate(&text[..], &MotionProfile::default()).unwrap();
        assert_eq!(timer.total_s(), whole.total_s);
        assert!(whole.total_s > 2.0, "{whole:?}");
    }
}
