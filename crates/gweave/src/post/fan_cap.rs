//! `gweave fan-cap`: lowers every part-cooling fan speed (`M106 S`) above a maximum to it (a
//! small printer whose fan at full PWM blows the nozzle cold). A throwaway example of adding
//! a pass (docs/architecture.md).

use std::io::Write;

use serde::Serialize;

use crate::eol::Eol;
use crate::options::Shape;
use crate::pass::{keep, Ctx, Flow, Pass, Step};
use crate::range::Range;
use crate::run::{Ran, Run};

/// A fan PWM duty, as `M106 S` takes it.
const PWM: Range<f64> = Range::new(0.0, 255.0, "");

crate::job_options! {
    /// What `gweave fan-cap` is given besides its file.
    pub struct FanCapOptions for "fan-cap" {
        /// Highest fan speed kept, PWM 0 to 255; a higher `M106 S` is lowered to it
        /// [default: 255].
        max: Option<f64> = Shape::new("PWM").range(PWM),
    }
}

/// What the run changed.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FanCapReport {
    /// `M106` lines read.
    pub fan_commands: u64,
    /// Of those, lowered to the maximum.
    pub capped: u64,
}

struct FanCap {
    max: f64,
    eol: Eol,
    report: FanCapReport,
}

impl Pass for FanCap {
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        self.eol.learn(ctx.line.eol);
        if !ctx.block.command.is_m(106) {
            return keep(ctx, out);
        }
        self.report.fan_commands += 1;
        match ctx.block.get(b'S') {
            Some(s) if s > self.max => {
                self.report.capped += 1;
                let text = format!("M106 S{} ; gweave fan-cap: was S{s}", self.max);
                self.eol.text(out, text.as_bytes(), ctx.line.eol)?;
                Ok(Flow::Continue)
            }
            _ => keep(ctx, out),
        }
    }
}

/// Runs the cap over the run's file.
pub fn fan_cap(options: &FanCapOptions, run: Run<'_>) -> crate::Result<(FanCapReport, Ran)> {
    let mut pass = FanCap { max: options.max.unwrap_or(PWM.max), eol: Eol::default(), report: FanCapReport::default() };
    let ran = run.run(&mut pass)?;
    Ok((pass.report, ran))
}
