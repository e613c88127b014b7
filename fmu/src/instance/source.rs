//! The SensorView source half of an instance ([`crate::descriptor::Role::Source`]): its String
//! parameters, the [`ViewSource`] built from them, and the `OSMPSensorViewOut` output.
//!
//! * The source is built from the parameters when first needed (a Get of an output during
//!   initialization, or `fmi2ExitInitializationMode`); a parameter change drops it.
//! * Initialization publishes the view at the start time (`fmi2SetupExperiment`); `fmi2DoStep(t, h)`
//!   publishes the view at `t + h`. A sensor stepped at `t` with the source's current output so sees
//!   the world at `t`.
//! * Outside the source's recording (before it, past the scenario's `duration_s` or the trace's last
//!   message) the output is 0/0/0 with `valid` false and `count` 0, status `fmi2OK`.
//! * A parameter the builder rejects (missing file, bad JSON, unknown sensor) is `fmi2Error` naming
//!   it; skipped trace frames are `fmi2Warning`s naming the frame; a trace that breaks off is
//!   `fmi2Error`.

use crate::descriptor::{SourceFrame, SourceSettings, ViewSource};
use crate::ffi::Fmi2Status;
use crate::logging::LogCategory;
use crate::variables::{Variable, vr};

use super::{DoubleBuffer, Instance, State::*};

/// A source's share of an instance (all back to the start on `fmi2Reset`).
#[derive(Default)]
pub(crate) struct SourceIo {
    /// `scenario`, `trace_path`, `sensor` (indexed by String VR): `Some` once explicitly set.
    strings: [Option<String>; 3],
    /// The source; `None` until built or after a parameter changed.
    source: Option<Box<dyn ViewSource>>,
    /// `OSMPSensorViewOut`.
    view_out: DoubleBuffer,
    /// The view at the start time is published.
    initial_published: bool,
}

impl SourceIo {
    /// The set value of a String parameter (`None`: the start value).
    pub(super) fn string(&self, vr: u32) -> Option<&str> {
        self.strings.get(vr as usize).and_then(|s| s.as_deref())
    }
}

/// What one publication did (computed while the source's frame is borrowed, logged after).
enum Published {
    View { bytes: usize, count: usize },
    Nothing,
}

impl Instance {
    pub(super) fn source_set_string(
        &mut self,
        vars: &[&'static Variable],
        values: &[Option<String>],
    ) -> Fmi2Status {
        const F: &str = "fmi2SetString";
        for (v, value) in vars.iter().zip(values) {
            let value = value.clone().expect("checked by set_string");
            self.debug(LogCategory::Fmi, || format!("{F}: {} = {value:?}", v.name));
            let slot = &mut self.src.strings[v.vr as usize];
            if slot.as_deref() != Some(value.as_str()) {
                *slot = Some(value);
                // Rebuild the source and recompute the initial outputs.
                self.src.source = None;
                self.src.initial_published = false;
                self.src.view_out.unpublish();
                self.rt.valid = false;
                self.rt.count = 0;
            }
        }
        Fmi2Status::Ok
    }

    pub(super) fn source_get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Fmi2Status {
        const F: &str = "fmi2GetInteger";
        let status = match self.source_ensure_initial_outputs(F) {
            Ok(s) => s,
            Err(s) => return s,
        };
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = match r {
                vr::source::integer::COUNT => self.rt.count,
                r => self.src.view_out.published[r as usize],
            };
        }
        status
    }

    pub(super) fn source_exit_initialization_mode(&mut self) -> Fmi2Status {
        const F: &str = "fmi2ExitInitializationMode";
        let status = match self.source_ensure_initial_outputs(F) {
            Ok(s) => s,
            Err(s) => return s,
        };
        self.state = SlaveInitialized;
        self.debug(LogCategory::Fmi, || format!("{F}: slave initialized"));
        status
    }

    /// In initialization mode, build the source and publish the view at the start time if not done
    /// yet (the outputs are InitialUnknowns). Elsewhere the outputs are what the last call
    /// published. `Err(status)` after logging (a failure moves the instance to `error`).
    pub(super) fn source_ensure_initial_outputs(
        &mut self,
        func: &str,
    ) -> Result<Fmi2Status, Fmi2Status> {
        if self.state != InitializationMode || self.src.initial_published {
            return Ok(Fmi2Status::Ok);
        }
        let mut status = Fmi2Status::Ok;
        if self.src.source.is_none() {
            status = self.build_source(func)?;
        }
        let t = self.rt.start_time_s;
        status = status.max(self.publish_view_at(func, t)?);
        self.src.initial_published = true;
        Ok(status)
    }

    /// Build the source from the parameters; warnings are logged.
    fn build_source(&mut self, func: &str) -> Result<Fmi2Status, Fmi2Status> {
        let role = self
            .desc
            .as_source()
            .expect("a source-only path reached on a sensor FMU");
        let settings = SourceSettings {
            scenario: self.src.string(vr::source::string::SCENARIO),
            trace_path: self.src.string(vr::source::string::TRACE_PATH),
            sensor: self.src.string(vr::source::string::SENSOR),
            resources_dir: self.resources_dir.as_deref(),
        };
        let build = match (role.build_source)(&settings) {
            Ok(b) => b,
            Err(msg) => return Err(self.fail(func, LogCategory::Fmi, &msg)),
        };
        for w in &build.warnings {
            self.log(
                Fmi2Status::Warning,
                LogCategory::Fmi,
                &format!("{func}: {w}"),
            );
        }
        self.debug(LogCategory::Fmi, || {
            format!("{func}: playing {}", build.summary)
        });
        self.src.source = Some(build.source);
        Ok(if build.warnings.is_empty() {
            Fmi2Status::Ok
        } else {
            Fmi2Status::Warning
        })
    }

    /// Publish the source's view at `t` (or "no view"); sets `valid` and `count`.
    fn publish_view_at(&mut self, func: &str, t: f64) -> Result<Fmi2Status, Fmi2Status> {
        let Some(source) = self.src.source.as_mut() else {
            return Err(self.fail(
                func,
                LogCategory::Fmi,
                "internal error: no source after initialization",
            ));
        };
        let mut notes = Vec::new();
        let view_out = &mut self.src.view_out;
        let result = source.view_at(t, &mut notes).and_then(|frame| match frame {
            Some(SourceFrame { bytes, count }) => view_out
                .publish_bytes(bytes)
                .map(|()| Published::View {
                    bytes: bytes.len(),
                    count,
                })
                .map_err(|e| format!("OSMPSensorViewOut: {e}")),
            None => {
                view_out.unpublish();
                Ok(Published::Nothing)
            }
        });
        let mut status = Fmi2Status::Ok;
        for note in &notes {
            self.log(
                Fmi2Status::Warning,
                LogCategory::Osi,
                &format!("{func}: {note}"),
            );
            status = Fmi2Status::Warning;
        }
        match result {
            Ok(Published::View { bytes, count }) => {
                self.rt.valid = true;
                self.rt.count = i32::try_from(count).unwrap_or(i32::MAX);
                self.rt.frames_published += 1;
                self.debug(LogCategory::Osmp, || {
                    format!(
                        "{func}: SensorView at t = {t} s: {bytes} bytes, {count} moving objects"
                    )
                });
            }
            Ok(Published::Nothing) => {
                self.rt.valid = false;
                self.rt.count = 0;
                self.debug(LogCategory::Osmp, || {
                    format!(
                        "{func}: no SensorView at t = {t} s (outside the recording); outputs \
                         0/0/0, valid = false"
                    )
                });
            }
            Err(msg) => {
                self.src.view_out.unpublish();
                self.rt.valid = false;
                self.rt.count = 0;
                return Err(self.fail(
                    func,
                    LogCategory::Osi,
                    &format!("the SensorView at t = {t} s: {msg}"),
                ));
            }
        }
        Ok(status)
    }

    pub(super) fn source_do_step(&mut self, t: f64, h: f64) -> Fmi2Status {
        const F: &str = "fmi2DoStep";
        match self.publish_view_at(F, t + h) {
            Ok(status) => {
                self.rt.last_successful_time_s = t + h;
                status
            }
            Err(status) => status,
        }
    }
}
