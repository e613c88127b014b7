//! OSI frame transforms: global → host vehicle → sensor, velocities, orientations and spherical
//! coordinates.
//!
//! # Frames (ISO 8855 axes everywhere: x forward, y left, z up; right-handed; m, rad, s)
//!
//! * **Global**: the frame of `SensorView.global_ground_truth`.
//! * **Object frame** (per OSI object): origin at the bounding-box centre `base.position`, axes rotated
//!   by `base.orientation`.
//! * **Host vehicle frame**: origin at the middle of the host's rear axle,
//!   `o_vehicle = base.position + R_host · bbcenter_to_rear` (`bbcenter_to_rear` is given in the host's
//!   object frame; absent → zero, i.e. the box centre), axes those of the host object.
//! * **Sensor frame**: `MountingPosition` relative to the host vehicle frame:
//!   `p_sensor = R_mount^T · (p_vehicle − mount.position)`.
//!
//! # Rotations
//!
//! An OSI `Orientation3d {roll φ, pitch θ, yaw ψ}` is the rotation
//! `R = Rz(ψ) · Ry(θ) · Rx(φ)` that maps local (child) coordinates to parent coordinates:
//! `p_parent = position + R · p_local` (OSI: "yaw first, then pitch about the new y, then roll about
//! the new x"). The inverse is `p_local = R^T · (p_parent − position)`, which is OSI's
//! `origin_sensor = Rot_{yaw,pitch,roll}(orientation) · (origin_ref − position)` written with the
//! transposed matrix. [`rpy_from_rotation`] inverts [`rotation_from_rpy`] (pitch in [−π/2, π/2]).
//!
//! # Velocities
//!
//! OSI `BaseMoving.velocity` is the velocity of the bounding-box centre in the global frame (m/s);
//! `orientation_rate` holds the time derivatives of (roll, pitch, yaw) (rad/s). They are turned into an
//! angular-velocity vector with [`angular_velocity_from_rates`]
//! (`ω = ψ̇·e_z + θ̇·Rz(ψ)·e_y + φ̇·Rz(ψ)·Ry(θ)·e_x`; for planar motion simply `(0, 0, ψ̇)`).
//! A point `p` rigidly attached to a body with centre `c`, velocity `v_c` and angular velocity `ω`
//! moves with `v_c + ω × (p − c)`. The velocity of a global point `p` (moving with `v`) as seen in the
//! rotating sensor frame with origin `s` (velocity `v_s`, angular velocity `ω_s`) is
//! `d/dt p_sensor = R_s^T · (v − v_s − ω_s × (p − s))` ([`SensorFrame::relative_velocity`]);
//! the range rate `d|p − s|/dt = (p − s)·(v − v_s) / |p − s|` does not depend on `ω_s`
//! ([`SensorFrame::range_rate`]).
//!
//! # Spherical coordinates ([`Spherical`])
//!
//! `distance r = |p|`, `azimuth = atan2(y, x)` (positive to the left, about +z, in (−π, π]),
//! `elevation = asin(z / r)` **positive upwards**, i.e. `x = r·cos(el)·cos(az)`,
//! `y = r·cos(el)·sin(az)`, `z = r·sin(el)`. This is the convention of the openMSL reference sensor
//! models (`z = r·sin(elevation)`). Read formally, OSI's `Spherical3d` (azimuth about z, then elevation
//! about the *new* y axis, right-hand rule) has positive elevation pointing **down**; osiris uses the
//! openMSL reading everywhere (OSI `Spherical3d` outputs and the perception extension alike).

use glam::{DMat3, DVec3};
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

/// An OSI `Vector3d` as a `DVec3` (absent vector or components count as 0).
pub fn vec3_from_osi(v: Option<&osi3::Vector3d>) -> DVec3 {
    match v {
        Some(v) => DVec3::new(v.x.unwrap_or(0.0), v.y.unwrap_or(0.0), v.z.unwrap_or(0.0)),
        None => DVec3::ZERO,
    }
}

/// A `DVec3` as an OSI `Vector3d` (all components set).
pub fn vec3_to_osi(v: DVec3) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(v.x),
        y: Some(v.y),
        z: Some(v.z),
    }
}

/// `(roll, pitch, yaw)` of an OSI `Orientation3d`, rad (absent values count as 0).
pub fn rpy_from_osi(o: Option<&osi3::Orientation3d>) -> [f64; 3] {
    match o {
        Some(o) => [
            o.roll.unwrap_or(0.0),
            o.pitch.unwrap_or(0.0),
            o.yaw.unwrap_or(0.0),
        ],
        None => [0.0; 3],
    }
}

/// `(roll, pitch, yaw)` (rad) as an OSI `Orientation3d` (all components set).
pub fn rpy_to_osi(rpy: [f64; 3]) -> osi3::Orientation3d {
    osi3::Orientation3d {
        roll: Some(rpy[0]),
        pitch: Some(rpy[1]),
        yaw: Some(rpy[2]),
    }
}

/// `R = Rz(yaw) · Ry(pitch) · Rx(roll)`: local → parent rotation of an OSI orientation.
pub fn rotation_from_rpy(roll: f64, pitch: f64, yaw: f64) -> DMat3 {
    DMat3::from_rotation_z(yaw) * DMat3::from_rotation_y(pitch) * DMat3::from_rotation_x(roll)
}

/// Rotation of an OSI `Orientation3d` (absent → identity), see [`rotation_from_rpy`].
pub fn rotation_from_osi(o: Option<&osi3::Orientation3d>) -> DMat3 {
    let [r, p, y] = rpy_from_osi(o);
    rotation_from_rpy(r, p, y)
}

/// `(roll, pitch, yaw)` of a rotation matrix, the inverse of [`rotation_from_rpy`]:
/// pitch in [−π/2, π/2], roll and yaw in (−π, π]. At the gimbal lock (|pitch| = π/2) roll is 0.
pub fn rpy_from_rotation(m: &DMat3) -> [f64; 3] {
    // Row-major names: r_ij = element (row i, column j); glam stores columns.
    let r00 = m.x_axis.x;
    let r10 = m.x_axis.y;
    let r20 = m.x_axis.z;
    let r21 = m.y_axis.z;
    let r22 = m.z_axis.z;
    let pitch = (-r20).clamp(-1.0, 1.0).asin();
    if r20.abs() < 1.0 - 1e-12 {
        [r21.atan2(r22), pitch, r10.atan2(r00)]
    } else {
        // cos(pitch) = 0: only yaw − roll (pitch = +π/2) or yaw + roll (−π/2) is defined; roll := 0.
        let r01 = m.y_axis.x;
        let r11 = m.y_axis.y;
        [0.0, pitch, (-r01).atan2(r11)]
    }
}

/// Angle wrapped into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = a.rem_euclid(TAU); // [0, 2π)
    if w > PI { w - TAU } else { w }
}

/// Angular-velocity vector (parent frame, rad/s) of a body with orientation `rpy = (φ, θ, ψ)` and
/// Euler-angle rates `rates = (φ̇, θ̇, ψ̇)` (OSI `orientation_rate`):
/// `ω = ψ̇·e_z + θ̇·Rz(ψ)·e_y + φ̇·Rz(ψ)·Ry(θ)·e_x`.
pub fn angular_velocity_from_rates(rpy: [f64; 3], rates: [f64; 3]) -> DVec3 {
    let rz = DMat3::from_rotation_z(rpy[2]);
    let rzy = rz * DMat3::from_rotation_y(rpy[1]);
    DVec3::Z * rates[2] + rz * DVec3::Y * rates[1] + rzy * DVec3::X * rates[0]
}

/// A rigid pose: a child frame expressed in its parent, `p_parent = position + rotation · p_local`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Origin of the child frame in parent coordinates, m.
    pub position: DVec3,
    /// Child → parent rotation (columns: the child's axes in parent coordinates).
    pub rotation: DMat3,
}

impl Default for Pose {
    fn default() -> Self {
        Pose::IDENTITY
    }
}

impl Pose {
    pub const IDENTITY: Pose = Pose {
        position: DVec3::ZERO,
        rotation: DMat3::IDENTITY,
    };

    pub fn new(position: DVec3, rotation: DMat3) -> Pose {
        Pose { position, rotation }
    }

    /// Pose from OSI position and orientation (absent parts: zero / identity).
    pub fn from_osi(
        position: Option<&osi3::Vector3d>,
        orientation: Option<&osi3::Orientation3d>,
    ) -> Pose {
        Pose {
            position: vec3_from_osi(position),
            rotation: rotation_from_osi(orientation),
        }
    }

    /// The sensor frame relative to the host vehicle frame, from an OSI `MountingPosition`.
    pub fn from_mounting(m: &osi3::MountingPosition) -> Pose {
        Pose::from_osi(m.position.as_ref(), m.orientation.as_ref())
    }

    /// Local point → parent coordinates.
    pub fn transform_point(&self, p_local: DVec3) -> DVec3 {
        self.position + self.rotation * p_local
    }

    /// Parent point → local coordinates: `R^T · (p − position)`.
    pub fn inverse_transform_point(&self, p_parent: DVec3) -> DVec3 {
        self.rotation.transpose() * (p_parent - self.position)
    }

    /// Local direction (free vector) → parent coordinates.
    pub fn transform_vector(&self, v_local: DVec3) -> DVec3 {
        self.rotation * v_local
    }

    /// Parent direction (free vector) → local coordinates.
    pub fn inverse_transform_vector(&self, v_parent: DVec3) -> DVec3 {
        self.rotation.transpose() * v_parent
    }

    /// `self ∘ child`: `child` is given in `self`'s local frame; the result is `child` in `self`'s parent.
    pub fn compose(&self, child: &Pose) -> Pose {
        Pose {
            position: self.transform_point(child.position),
            rotation: self.rotation * child.rotation,
        }
    }

    /// The parent expressed in the child frame.
    pub fn inverse(&self) -> Pose {
        let rt = self.rotation.transpose();
        Pose {
            position: -(rt * self.position),
            rotation: rt,
        }
    }
}

/// Global pose of an OSI moving object's bounding box (centre and orientation).
pub fn moving_object_pose(obj: &osi3::MovingObject) -> Pose {
    let base = obj.base.as_ref();
    Pose::from_osi(
        base.and_then(|b| b.position.as_ref()),
        base.and_then(|b| b.orientation.as_ref()),
    )
}

/// Global pose of an OSI stationary object's bounding box (centre and orientation).
pub fn stationary_object_pose(obj: &osi3::StationaryObject) -> Pose {
    let base = obj.base.as_ref();
    Pose::from_osi(
        base.and_then(|b| b.position.as_ref()),
        base.and_then(|b| b.orientation.as_ref()),
    )
}

/// Linear (m/s) and angular (rad/s) velocity of an OSI moving object's box centre, global frame.
pub fn moving_object_twist(obj: &osi3::MovingObject) -> (DVec3, DVec3) {
    let Some(base) = obj.base.as_ref() else {
        return (DVec3::ZERO, DVec3::ZERO);
    };
    let v = vec3_from_osi(base.velocity.as_ref());
    let w = angular_velocity_from_rates(
        rpy_from_osi(base.orientation.as_ref()),
        rpy_from_osi(base.orientation_rate.as_ref()),
    );
    (v, w)
}

/// Global pose of the host vehicle frame (rear-axle centre, host axes):
/// `position = base.position + R_host · bbcenter_to_rear` (missing `bbcenter_to_rear` → zero).
pub fn host_vehicle_pose(host: &osi3::MovingObject) -> Pose {
    let bb = moving_object_pose(host);
    let to_rear = vec3_from_osi(
        host.vehicle_attributes
            .as_ref()
            .and_then(|a| a.bbcenter_to_rear.as_ref()),
    );
    Pose {
        position: bb.transform_point(to_rear),
        rotation: bb.rotation,
    }
}

/// A sensor frame moving with the host vehicle: its global pose plus the global linear velocity of
/// its origin and its global angular velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorFrame {
    /// Sensor frame in global coordinates.
    pub pose: Pose,
    /// Global velocity of the sensor origin, m/s.
    pub velocity: DVec3,
    /// Global angular velocity of the sensor frame (= the host's), rad/s.
    pub angular_velocity: DVec3,
}

impl SensorFrame {
    /// Sensor frame of a sensor mounted on `host` (None: the vehicle frame is the global frame at
    /// rest, as on a static test bench). The sensor origin moves rigidly with the host:
    /// `v_s = v_host + ω_host × (s − c_host)`.
    pub fn new(
        host: Option<&osi3::MovingObject>,
        mounting: &osi3::MountingPosition,
    ) -> SensorFrame {
        let mount = Pose::from_mounting(mounting);
        match host {
            Some(host) => {
                let vehicle = host_vehicle_pose(host);
                let pose = vehicle.compose(&mount);
                let centre = moving_object_pose(host).position;
                let (v, w) = moving_object_twist(host);
                SensorFrame {
                    pose,
                    velocity: v + w.cross(pose.position - centre),
                    angular_velocity: w,
                }
            }
            None => SensorFrame {
                pose: mount,
                velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
            },
        }
    }

    /// A sensor frame at rest with the given global pose.
    pub fn at_rest(pose: Pose) -> SensorFrame {
        SensorFrame {
            pose,
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
        }
    }

    /// Global point → sensor coordinates.
    pub fn point_to_sensor(&self, p_global: DVec3) -> DVec3 {
        self.pose.inverse_transform_point(p_global)
    }

    /// Sensor point → global coordinates.
    pub fn point_to_global(&self, p_sensor: DVec3) -> DVec3 {
        self.pose.transform_point(p_sensor)
    }

    /// Global direction → sensor coordinates.
    pub fn vector_to_sensor(&self, v_global: DVec3) -> DVec3 {
        self.pose.inverse_transform_vector(v_global)
    }

    /// Global orientation (local → global rotation) → orientation relative to the sensor (`R_s^T · R`).
    pub fn rotation_to_sensor(&self, r_global: &DMat3) -> DMat3 {
        self.pose.rotation.transpose() * *r_global
    }

    /// `(roll, pitch, yaw)` of a global orientation relative to the sensor frame.
    pub fn rpy_in_sensor(&self, r_global: &DMat3) -> [f64; 3] {
        rpy_from_rotation(&self.rotation_to_sensor(r_global))
    }

    /// Velocity (sensor coordinates, m/s) of a global point `p` moving with global velocity `v`, as seen
    /// from the moving, rotating sensor frame: `R_s^T · (v − v_s − ω_s × (p − s))`.
    pub fn relative_velocity(&self, p_global: DVec3, v_global: DVec3) -> DVec3 {
        let r = p_global - self.pose.position;
        self.vector_to_sensor(v_global - self.velocity - self.angular_velocity.cross(r))
    }

    /// Range rate `d|p − s|/dt` (m/s, positive when the point moves away from the sensor).
    /// Returns 0 for a point at the sensor origin.
    pub fn range_rate(&self, p_global: DVec3, v_global: DVec3) -> f64 {
        let r = p_global - self.pose.position;
        let n = r.length();
        if n > 0.0 {
            r.dot(v_global - self.velocity) / n
        } else {
            0.0
        }
    }
}

/// Spherical coordinates in a sensor frame (openMSL convention, elevation positive **up**; see the
/// module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spherical {
    /// m
    pub distance: f64,
    /// rad, `atan2(y, x)`, positive to the left.
    pub azimuth: f64,
    /// rad, `asin(z / r)`, positive upwards.
    pub elevation: f64,
}

impl Spherical {
    /// Cartesian → spherical. The origin maps to (0, 0, 0).
    pub fn from_cartesian(p: DVec3) -> Spherical {
        let r = p.length();
        if r == 0.0 {
            return Spherical {
                distance: 0.0,
                azimuth: 0.0,
                elevation: 0.0,
            };
        }
        Spherical {
            distance: r,
            azimuth: p.y.atan2(p.x),
            elevation: (p.z / r).clamp(-1.0, 1.0).asin(),
        }
    }

    /// Spherical → cartesian: `(r cos el cos az, r cos el sin az, r sin el)`.
    pub fn to_cartesian(&self) -> DVec3 {
        let (se, ce) = self.elevation.sin_cos();
        let (sa, ca) = self.azimuth.sin_cos();
        self.distance * DVec3::new(ce * ca, ce * sa, se)
    }

    pub fn to_osi(&self) -> osi3::Spherical3d {
        osi3::Spherical3d {
            distance: Some(self.distance),
            azimuth: Some(self.azimuth),
            elevation: Some(self.elevation),
        }
    }

    /// From an OSI `Spherical3d` (absent values count as 0), read with the same convention.
    pub fn from_osi(s: &osi3::Spherical3d) -> Spherical {
        Spherical {
            distance: s.distance.unwrap_or(0.0),
            azimuth: s.azimuth.unwrap_or(0.0),
            elevation: s.elevation.unwrap_or(0.0),
        }
    }
}

/// A mounting pose: the sensor frame relative to the host vehicle frame (rear-axle centre, ISO 8855),
/// as OSI `MountingPosition` (position m, orientation rad: roll, pitch, yaw).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mounting {
    pub position_m: [f64; 3],
    #[serde(default)]
    pub orientation_rad: [f64; 3],
}

impl Mounting {
    pub fn to_osi(&self) -> osi3::MountingPosition {
        osi3::MountingPosition {
            position: Some(osi3::Vector3d {
                x: Some(self.position_m[0]),
                y: Some(self.position_m[1]),
                z: Some(self.position_m[2]),
            }),
            orientation: Some(osi3::Orientation3d {
                roll: Some(self.orientation_rad[0]),
                pitch: Some(self.orientation_rad[1]),
                yaw: Some(self.orientation_rad[2]),
            }),
        }
    }
}

/// Largest mounting angle error the `calibration` block accepts, deg (a bent bracket or a
/// misaligned bumper radar is off by tenths of a degree to a few degrees; beyond this the sensor
/// is mis-mounted, not miscalibrated).
pub const MAX_CALIBRATION_ANGLE_DEG: f64 = 10.0;
/// Largest mounting translation error the `calibration` block accepts, m.
pub const MAX_CALIBRATION_TRANSLATION_M: f64 = 1.0;
/// Largest clock offset the `calibration` block accepts, s.
pub const MAX_TIME_OFFSET_S: f64 = 1.0;
/// Largest clock drift the `calibration` block accepts, ppm (quartz oscillators: tens of ppm).
pub const MAX_TIME_DRIFT_PPM: f64 = 1000.0;

/// How a real sensor differs from its nominal mounting and clock (the configuration's
/// `calibration` block; every key defaults to 0).
///
/// * **Extrinsic error** (`roll_deg`, `pitch_deg`, `yaw_deg`, `x_m`, `y_m`, `z_m`): the pose of the
///   sensor's *true* frame in its *nominal* frame (the one `mounting` gives): rotation
///   `R_E = Rz(yaw)·Ry(pitch)·Rx(roll)` about the nominal sensor axes and the translation
///   `t_E = (x, y, z)` in the nominal sensor axes, so the true mounting is
///   `M_true = M_nom ∘ E` (`p_host = p_nom + R_nom·(t_E + R_E·p_true)`). The sensor measures in its
///   true frame and reports the numbers as if they were in the nominal one: a target at azimuth θ
///   in the nominal frame is reported at θ − yaw; a sensor moved by `y_m` to the left reports the
///   target `y_m` further right.
/// * **Time offset** (`time_offset_s`, `time_drift_ppm`): the sensor measures the world at
///   `t + Δt(t)`, `Δt(t) = time_offset_s + time_drift_ppm·10⁻⁶·t` (t the ground-truth time, s),
///   and stamps the measurement `t`: a target moving at `v_rel` relative to the sensor is reported
///   `v_rel·Δt` off.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Calibration {
    /// Roll of the true sensor frame about the nominal sensor x axis, deg.
    pub roll_deg: f64,
    /// Pitch of the true sensor frame about the nominal sensor y axis, deg (positive: looks down).
    pub pitch_deg: f64,
    /// Yaw of the true sensor frame about the nominal sensor z axis, deg (positive: looks left).
    pub yaw_deg: f64,
    /// Offset of the true sensor origin along the nominal sensor x axis, m.
    pub x_m: f64,
    /// Offset of the true sensor origin along the nominal sensor y axis, m.
    pub y_m: f64,
    /// Offset of the true sensor origin along the nominal sensor z axis, m.
    pub z_m: f64,
    /// Constant clock offset: the sensor measures at ground-truth time + this, s.
    pub time_offset_s: f64,
    /// Clock drift, ppm: the offset grows by `time_drift_ppm·10⁻⁶` s per second of ground-truth time.
    pub time_drift_ppm: f64,
}

impl Calibration {
    /// The true sensor frame in the nominal sensor frame (see the type's documentation).
    pub fn pose(&self) -> Pose {
        Pose::new(
            DVec3::new(self.x_m, self.y_m, self.z_m),
            rotation_from_rpy(
                self.roll_deg.to_radians(),
                self.pitch_deg.to_radians(),
                self.yaw_deg.to_radians(),
            ),
        )
    }

    /// Whether any of the extrinsic (pose) errors is non-zero.
    pub fn has_extrinsic_error(&self) -> bool {
        [
            self.roll_deg,
            self.pitch_deg,
            self.yaw_deg,
            self.x_m,
            self.y_m,
            self.z_m,
        ]
        .iter()
        .any(|v| *v != 0.0)
    }

    /// The clock offset at ground-truth time `t_s`: `time_offset_s + time_drift_ppm·10⁻⁶·t_s`, s.
    pub fn time_offset_at(&self, t_s: f64) -> f64 {
        self.time_offset_s + self.time_drift_ppm * 1e-6 * t_s
    }

    /// The true mounting of a sensor whose nominal mounting is `nominal`: `M_nom ∘ E`.
    pub fn true_mounting(&self, nominal: &osi3::MountingPosition) -> osi3::MountingPosition {
        let m = Pose::from_mounting(nominal).compose(&self.pose());
        osi3::MountingPosition {
            position: Some(vec3_to_osi(m.position)),
            orientation: Some(rpy_to_osi(rpy_from_rotation(&m.rotation))),
        }
    }

    /// Check every value: finite and within the plausible bounds; the error names the key
    /// (`calibration.<key>`) and the value.
    pub fn validate(&self) -> Result<(), String> {
        let check = |key: &str, v: f64, max: f64| {
            if v.is_finite() && v.abs() <= max {
                Ok(())
            } else {
                Err(format!(
                    "`calibration.{key}` must be a finite number with |value| <= {max}, got {v}"
                ))
            }
        };
        check("roll_deg", self.roll_deg, MAX_CALIBRATION_ANGLE_DEG)?;
        check("pitch_deg", self.pitch_deg, MAX_CALIBRATION_ANGLE_DEG)?;
        check("yaw_deg", self.yaw_deg, MAX_CALIBRATION_ANGLE_DEG)?;
        check("x_m", self.x_m, MAX_CALIBRATION_TRANSLATION_M)?;
        check("y_m", self.y_m, MAX_CALIBRATION_TRANSLATION_M)?;
        check("z_m", self.z_m, MAX_CALIBRATION_TRANSLATION_M)?;
        check("time_offset_s", self.time_offset_s, MAX_TIME_OFFSET_S)?;
        check("time_drift_ppm", self.time_drift_ppm, MAX_TIME_DRIFT_PPM)?;
        Ok(())
    }

    /// All zero (nothing to apply).
    pub fn is_zero(&self) -> bool {
        *self == Calibration::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-9
    }

    fn host(
        pos: [f64; 3],
        yaw: f64,
        vel: [f64; 3],
        yaw_rate: f64,
        to_rear: Option<[f64; 3]>,
    ) -> osi3::MovingObject {
        let v = |a: [f64; 3]| osi3::Vector3d {
            x: Some(a[0]),
            y: Some(a[1]),
            z: Some(a[2]),
        };
        osi3::MovingObject {
            id: Some(osiris_proto::id(1)),
            base: Some(osi3::BaseMoving {
                position: Some(v(pos)),
                orientation: Some(rpy_to_osi([0.0, 0.0, yaw])),
                velocity: Some(v(vel)),
                orientation_rate: Some(rpy_to_osi([0.0, 0.0, yaw_rate])),
                ..Default::default()
            }),
            vehicle_attributes: to_rear.map(|r| osi3::moving_object::VehicleAttributes {
                bbcenter_to_rear: Some(v(r)),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    fn mounting(pos: [f64; 3], rpy: [f64; 3]) -> osi3::MountingPosition {
        super::Mounting {
            position_m: pos,
            orientation_rad: rpy,
        }
        .to_osi()
    }

    #[test]
    fn rotation_matches_closed_forms() {
        // Yaw 90°: local x → global y, local y → global −x.
        let r = rotation_from_rpy(0.0, 0.0, FRAC_PI_2);
        assert!(close(r * DVec3::X, DVec3::Y));
        assert!(close(r * DVec3::Y, -DVec3::X));
        // Pitch 90° (nose down in ISO 8855 with positive pitch about +y): local x → global −z.
        let r = rotation_from_rpy(0.0, FRAC_PI_2, 0.0);
        assert!(close(r * DVec3::X, -DVec3::Z));
        // Roll 90°: local y → global z.
        let r = rotation_from_rpy(FRAC_PI_2, 0.0, 0.0);
        assert!(close(r * DVec3::Y, DVec3::Z));
        // Order: yaw applied last (outermost). Roll 90° then yaw 90°: local y → z, local z → −y → x.
        let r = rotation_from_rpy(FRAC_PI_2, 0.0, FRAC_PI_2);
        assert!(close(r * DVec3::Y, DVec3::Z));
        assert!(close(r * DVec3::Z, DVec3::X));
    }

    #[test]
    fn rpy_round_trip() {
        for &(r, p, y) in &[
            (0.1, -0.2, 0.3),
            (-2.5, 1.2, -3.0),
            (3.0, -1.5, 2.0),
            (0.0, 0.0, PI - 1e-6),
            (0.7, 0.0, -0.7),
        ] {
            let m = rotation_from_rpy(r, p, y);
            let [r2, p2, y2] = rpy_from_rotation(&m);
            assert!(
                (r2 - r).abs() < 1e-9 && (p2 - p).abs() < 1e-9 && (y2 - y).abs() < 1e-9,
                "{r} {p} {y}"
            );
        }
        // Gimbal lock: the recovered angles reproduce the matrix.
        let m = rotation_from_rpy(0.4, FRAC_PI_2, 0.9);
        let [r2, p2, y2] = rpy_from_rotation(&m);
        let m2 = rotation_from_rpy(r2, p2, y2);
        assert!((m - m2).to_cols_array().iter().all(|d| d.abs() < 1e-9));
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-12);
        assert!((wrap_angle(2.0 * PI + 0.25) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn pose_compose_inverse_round_trip() {
        let a = Pose::new(DVec3::new(1.0, -2.0, 0.5), rotation_from_rpy(0.1, 0.2, 0.3));
        let b = Pose::new(
            DVec3::new(-0.3, 4.0, 1.0),
            rotation_from_rpy(-0.4, 0.05, 2.0),
        );
        let p = DVec3::new(7.0, -3.0, 2.0);
        let ab = a.compose(&b);
        assert!(close(
            ab.transform_point(p),
            a.transform_point(b.transform_point(p))
        ));
        assert!(close(ab.inverse_transform_point(ab.transform_point(p)), p));
        assert!(close(
            ab.inverse().transform_point(p),
            ab.inverse_transform_point(p)
        ));
    }

    #[test]
    fn host_vehicle_frame_uses_bbcenter_to_rear_in_object_axes() {
        // Host centre at (10, 5, 0.75) heading 90° (towards +y); rear axle 1.4 m behind the centre.
        let h = host(
            [10.0, 5.0, 0.75],
            FRAC_PI_2,
            [0.0; 3],
            0.0,
            Some([-1.4, 0.0, -0.4]),
        );
        let pose = host_vehicle_pose(&h);
        // Behind = −y globally when heading +y.
        assert!(close(pose.position, DVec3::new(10.0, 3.6, 0.35)));
        // Missing bbcenter_to_rear → the box centre.
        let h = host([10.0, 5.0, 0.75], FRAC_PI_2, [0.0; 3], 0.0, None);
        assert!(close(
            host_vehicle_pose(&h).position,
            DVec3::new(10.0, 5.0, 0.75)
        ));
    }

    #[test]
    fn global_to_sensor_rotated_host_and_mount() {
        // Host heading 90°, rear axle at (10, 3.6, 0.35). Sensor 2 m ahead of the rear axle, 1 m up,
        // yawed 90° to the left (looking along the vehicle's +y = global −x).
        let h = host(
            [10.0, 5.0, 0.75],
            FRAC_PI_2,
            [0.0; 3],
            0.0,
            Some([-1.4, 0.0, -0.4]),
        );
        let f = SensorFrame::new(Some(&h), &mounting([2.0, 0.0, 1.0], [0.0, 0.0, FRAC_PI_2]));
        // Sensor origin: rear axle + R_host·(2,0,1) = (10, 3.6+2, 1.35).
        assert!(close(f.pose.position, DVec3::new(10.0, 5.6, 1.35)));
        // A point 20 m to the vehicle's left of the sensor is global −x of it: straight ahead.
        let p = DVec3::new(10.0 - 20.0, 5.6, 1.35);
        assert!(close(f.point_to_sensor(p), DVec3::new(20.0, 0.0, 0.0)));
        // A point 5 m further along the vehicle's heading (+y global) is to the sensor's right.
        let p = DVec3::new(10.0, 5.6 + 5.0, 1.35);
        assert!(close(f.point_to_sensor(p), DVec3::new(0.0, -5.0, 0.0)));
        // Round trip.
        let q = DVec3::new(3.0, -7.0, 2.5);
        assert!(close(f.point_to_global(f.point_to_sensor(q)), q));
        // Orientation: an object heading global +x (yaw 0) relative to a sensor looking along global −x.
        let rel = f.rpy_in_sensor(&rotation_from_rpy(0.0, 0.0, 0.0));
        assert!((wrap_angle(rel[2]) - PI).abs() < 1e-9);
        // Relative yaw of an object heading global +y (the vehicle's heading): −90° for this sensor.
        let rel = f.rpy_in_sensor(&rotation_from_rpy(0.0, 0.0, FRAC_PI_2));
        assert!((rel[2] + FRAC_PI_2).abs() < 1e-9);
    }

    #[test]
    fn mounting_pitch_and_roll() {
        // Host at the origin, identity. Sensor pitched down 45° (positive pitch = nose down).
        let h = host([0.0; 3], 0.0, [0.0; 3], 0.0, None);
        let f = SensorFrame::new(Some(&h), &mounting([0.0, 0.0, 1.0], [0.0, FRAC_PI_4, 0.0]));
        // A ground point 1 m ahead, 1 m below the sensor, lies on the sensor's +x axis.
        let p = f.point_to_sensor(DVec3::new(1.0, 0.0, 0.0));
        assert!(close(p, DVec3::new(2f64.sqrt(), 0.0, 0.0)));
    }

    #[test]
    fn relative_velocity_translation_and_yaw_rate() {
        // Host at the origin moving +x at 10 m/s, sensor at the rear axle (no offsets).
        let h = host([0.0; 3], 0.0, [10.0, 0.0, 0.0], 0.0, None);
        let f = SensorFrame::new(Some(&h), &mounting([0.0; 3], [0.0; 3]));
        // Stationary target 50 m ahead: approaches at 10 m/s.
        let p = DVec3::new(50.0, 0.0, 0.0);
        assert!(close(
            f.relative_velocity(p, DVec3::ZERO),
            DVec3::new(-10.0, 0.0, 0.0)
        ));
        assert!((f.range_rate(p, DVec3::ZERO) + 10.0).abs() < 1e-12);
        // Target ahead driving 15 m/s: recedes at 5 m/s.
        assert!((f.range_rate(p, DVec3::new(15.0, 0.0, 0.0)) - 5.0).abs() < 1e-12);

        // Host turning left at 0.1 rad/s, standing still: a stationary point 50 m ahead appears to move
        // to the right at ω·r = 5 m/s; the range rate is 0.
        let h = host([0.0; 3], 0.0, [0.0; 3], 0.1, None);
        let f = SensorFrame::new(Some(&h), &mounting([0.0; 3], [0.0; 3]));
        assert!(close(
            f.relative_velocity(p, DVec3::ZERO),
            DVec3::new(0.0, -5.0, 0.0)
        ));
        assert!(f.range_rate(p, DVec3::ZERO).abs() < 1e-12);

        // Sensor mounted 2 m ahead of the centre of a host turning at 0.5 rad/s: the sensor origin
        // moves sideways (+y) at 1 m/s.
        let h = host([0.0; 3], 0.0, [0.0; 3], 0.5, None);
        let f = SensorFrame::new(Some(&h), &mounting([2.0, 0.0, 0.0], [0.0; 3]));
        assert!(close(f.velocity, DVec3::new(0.0, 1.0, 0.0)));
        assert!(close(f.angular_velocity, DVec3::new(0.0, 0.0, 0.5)));
    }

    #[test]
    fn relative_velocity_in_yawed_sensor() {
        // Host moving +x at 20 m/s; sensor looking left (yaw 90°, its +y is the vehicle's −x). A
        // stationary point to the left drifts backwards, i.e. to the sensor's left (+y_sensor) at 20 m/s.
        let h = host([0.0; 3], 0.0, [20.0, 0.0, 0.0], 0.0, None);
        let f = SensorFrame::new(Some(&h), &mounting([0.0; 3], [0.0, 0.0, FRAC_PI_2]));
        let p = DVec3::new(0.0, 10.0, 0.0);
        assert!(close(
            f.relative_velocity(p, DVec3::ZERO),
            DVec3::new(0.0, 20.0, 0.0)
        ));
    }

    #[test]
    fn angular_velocity_from_euler_rates() {
        // Planar motion: only yaw rate.
        assert!(close(
            angular_velocity_from_rates([0.3, 0.0, 1.0], [0.0, 0.0, 0.2]),
            DVec3::new(0.0, 0.0, 0.2)
        ));
        // Pitch rate with yaw 90°: rotation about the yawed y axis = global −x.
        assert!(close(
            angular_velocity_from_rates([0.0, 0.0, FRAC_PI_2], [0.0, 0.5, 0.0]),
            DVec3::new(-0.5, 0.0, 0.0)
        ));
    }

    #[test]
    fn spherical_convention_and_round_trip() {
        // Left is positive azimuth, up is positive elevation.
        let s = Spherical::from_cartesian(DVec3::new(0.0, 5.0, 0.0));
        assert!((s.azimuth - FRAC_PI_2).abs() < 1e-12 && s.elevation.abs() < 1e-12);
        let s = Spherical::from_cartesian(DVec3::new(1.0, 0.0, 1.0));
        assert!(
            (s.elevation - FRAC_PI_4).abs() < 1e-12 && (s.distance - 2f64.sqrt()).abs() < 1e-12
        );
        let s = Spherical::from_cartesian(DVec3::new(-3.0, -4.0, -12.0));
        assert!((s.distance - 13.0).abs() < 1e-12);
        assert!(s.elevation < 0.0);
        assert!(close(s.to_cartesian(), DVec3::new(-3.0, -4.0, -12.0)));
        let back = Spherical::from_osi(&s.to_osi());
        assert_eq!(back, s);
        assert_eq!(Spherical::from_cartesian(DVec3::ZERO).distance, 0.0);
    }
}
