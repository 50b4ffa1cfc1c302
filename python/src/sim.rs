//! `Sim`: the closed-loop step API from Python. The simulator lives on its own thread (it holds
//! the renderer's sensor, which is not `Send`); each call sends it a request and waits for the
//! answer with the GIL released, so other Python threads run while a frame renders.

use std::path::PathBuf;
use std::sync::mpsc;

use nalgebra::Isometry3;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use synthcam::dataset::MeshLibrary;
use synthcam::render::GreyImage;
use synthcam::scene::file::CameraSpec;
use synthcam::sim::sensor::RenderedSensor;
use synthcam::sim::{Observation, ScenarioSpec, Sim as LibSim};

use crate::convert::{chain, err, image_to_py, isometry_rows, optional_points_to_py, points_to_py, text_or_json, to_py};

/// What Python asks the simulator thread.
enum Request {
    Observe,
    ObserveGoal,
    Command { qdot: Vec<f64>, dt_s: f64 },
    SetJoints(Vec<f64>),
    Restart { q: Vec<f64>, seed: Option<u64> },
    Project(Vec<f64>),
}

/// Its answers.
enum Reply {
    Observation(Box<Observation>),
    Done,
    Pixels(Vec<Option<nalgebra::Point2<f64>>>),
}

type Job = (Request, mpsc::Sender<Result<Reply, String>>);

/// What does not change over a run, read once at start.
#[derive(Clone, serde::Serialize)]
struct Info {
    robot: String,
    dof: usize,
    features: usize,
    camera: CameraSpec,
    tool_from_cam: [[f64; 4]; 4],
    goal_cam_from_target: [[f64; 4]; 4],
    q_start_rad: Vec<f64>,
}

/// The built-in scenarios by name.
fn scenario_text(name_or_text: &str) -> String {
    match name_or_text {
        "ur5e_chessboard" => synthcam::sim::UR5E_CHESSBOARD.to_owned(),
        "course" => synthcam::course::SCENARIO.to_owned(),
        other => other.to_owned(),
    }
}

/// Build the simulator on this thread and serve requests until the Python object is dropped.
fn serve(text: String, base: PathBuf, ready: mpsc::Sender<Result<Info, String>>, jobs: mpsc::Receiver<Job>) {
    let built = (|| -> Result<_, String> {
        let spec = ScenarioSpec::parse(&text).map_err(|e| format!("in the scenario: {}", chain(&e)))?;
        let robot =
            spec.robot.build(&|p| std::fs::read_to_string(base.join(p)).map_err(|e| format!("{}: {e}", base.join(p).display()))).map_err(|e| chain(&e))?;
        let meshes = MeshLibrary::new(&base);
        let scenario = spec.to_scenario_with(&|p: &str| meshes.load(p)).map_err(|e| chain(&e))?;
        let renderer = crate::render::renderer()?;
        let sim = LibSim::new(scenario, robot, Box::new(RenderedSensor::new(renderer))).map_err(|e| chain(&e))?;
        let sc = sim.scenario();
        let info = Info {
            robot: sim.robot().name().to_owned(),
            dof: sim.robot().dof(),
            features: sc.target.feature_points_m().len(),
            camera: CameraSpec::from_model(&sc.camera),
            tool_from_cam: isometry_rows(&sc.tool_from_cam),
            goal_cam_from_target: isometry_rows(&sc.goal_cam_from_target),
            q_start_rad: sim.joints().to_vec(),
        };
        Ok((sim, info))
    })();
    let mut sim = match built {
        Ok((sim, info)) => {
            let _ = ready.send(Ok(info));
            sim
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    for (request, answer) in jobs {
        let _ = answer.send(handle(&mut sim, request));
    }
}

fn handle(sim: &mut LibSim<'_>, request: Request) -> Result<Reply, String> {
    let e = |e: synthcam::sim::SimError| chain(&e);
    match request {
        Request::Observe => sim.observe().map(|o| Reply::Observation(Box::new(o))).map_err(e),
        Request::ObserveGoal => {
            let goal: Isometry3<f64> = sim.scenario().goal_cam_from_target;
            sim.observe_from(goal).map(|o| Reply::Observation(Box::new(o))).map_err(e)
        }
        Request::Command { qdot, dt_s } => sim.command_joint_velocities(&qdot, dt_s).map(|()| Reply::Done).map_err(e),
        Request::SetJoints(q) => sim.set_joints(&q).map(|()| Reply::Done).map_err(e),
        Request::Restart { q, seed } => sim.restart(&q, seed).map(|()| Reply::Done).map_err(e),
        Request::Project(q) => sim.projected_px_at(&q).map(Reply::Pixels).map_err(e),
    }
}

/// A robot, a camera on its tool and a target, in the loop: render, detect, command, move.
///
/// `scenario`: "ur5e_chessboard" (default), "course", or an open scenario's TOML/JSON text or
/// dict (`assets/scenarios/*.toml`); URDF and mesh paths in it are read relative to `base_dir`
/// (default: the working directory). Every observation renders the camera's view on the GPU
/// and runs synthcam's detector on the pixels; the GIL is released meanwhile.
#[pyclass(name = "Sim", module = "synthcam")]
pub struct PySim {
    jobs: Option<mpsc::Sender<Job>>,
    info: Info,
}

impl PySim {
    fn call(&self, py: Python<'_>, request: Request) -> PyResult<Reply> {
        let jobs = self.jobs.as_ref().ok_or_else(|| err("the simulator is closed"))?.clone();
        py.detach(move || {
            let (tx, rx) = mpsc::channel();
            jobs.send((request, tx)).map_err(|_| "the simulator thread has stopped".to_owned())?;
            rx.recv().map_err(|_| "the simulator thread has stopped".to_owned())?
        })
        .map_err(err)
    }

    fn observation<'py>(&self, py: Python<'py>, request: Request, image: bool) -> PyResult<Bound<'py, PyDict>> {
        let Reply::Observation(o) = self.call(py, request)? else { return Err(err("unexpected reply")) };
        let out = PyDict::new(py);
        out.set_item("frame", o.frame)?;
        out.set_item("time_s", o.time_s)?;
        out.set_item("q_rad", o.q_rad.clone())?;
        out.set_item("ids", o.features.iter().map(|f| f.id).collect::<Vec<_>>())?;
        out.set_item("pixels_px", points_to_py(py, o.features.iter().map(|f| [f.pixel_px.x, f.pixel_px.y]))?)?;
        out.set_item("note", o.note.clone())?;
        out.set_item("render_ms", o.render_ms)?;
        out.set_item("detect_ms", o.detect_ms)?;
        out.set_item("cam_from_target", isometry_rows(&o.truth.cam_from_target))?;
        out.set_item("world_from_cam", isometry_rows(&o.truth.world_from_cam))?;
        out.set_item("truth_px", optional_points_to_py(py, &o.truth.projected_px)?)?;
        let img: Option<GreyImage> = if image { o.image } else { None };
        out.set_item("image", img.map(|i| image_to_py(py, i)).transpose()?)?;
        Ok(out)
    }
}

#[pymethods]
impl PySim {
    #[new]
    #[pyo3(signature = (scenario=None, base_dir=None))]
    fn new(py: Python<'_>, scenario: Option<&Bound<'_, PyAny>>, base_dir: Option<PathBuf>) -> PyResult<Self> {
        let text = scenario_text(&scenario.map(|s| text_or_json(s, "scenario")).transpose()?.unwrap_or_else(|| "ur5e_chessboard".into()));
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let (ready_tx, ready_rx) = mpsc::channel();
        let (jobs_tx, jobs_rx) = mpsc::channel();
        std::thread::Builder::new()
            .name("synthcam-sim".into())
            .spawn(move || serve(text, base, ready_tx, jobs_rx))
            .map_err(|e| err(format!("cannot start the simulator thread: {e}")))?;
        let info = py.detach(move || ready_rx.recv().map_err(|_| "the simulator thread stopped while starting".to_owned())?).map_err(err)?;
        Ok(Self { jobs: Some(jobs_tx), info })
    }

    /// Render and detect from the robot's current joints. Returns a dict: `frame`, `time_s`,
    /// `q_rad`, `ids` (feature ids found) and `pixels_px` ((N, 2), detected), `note`,
    /// `render_ms`, `detect_ms`, the truth (`cam_from_target`, `world_from_cam` as 4 x 4,
    /// `truth_px`: every feature's exact pixel, NaN where not visible) and `image` (a NumPy array
    /// when `image=True`, else None).
    #[pyo3(signature = (image=false))]
    fn observe<'py>(&self, py: Python<'py>, image: bool) -> PyResult<Bound<'py, PyDict>> {
        self.observation(py, Request::Observe, image)
    }

    /// Render and detect with the camera at the scenario's goal pose (teaching the desired
    /// features by showing). Same dict as `observe`.
    #[pyo3(signature = (image=false))]
    fn observe_goal<'py>(&self, py: Python<'py>, image: bool) -> PyResult<Bound<'py, PyDict>> {
        self.observation(py, Request::ObserveGoal, image)
    }

    /// Apply joint velocities `qdot` (rad/s, one per joint) for `dt_s` seconds. Velocities above
    /// a joint's limit are scaled down as a whole; a command that would cross a position limit is
    /// refused (`SynthcamError`) and the joints stay where they are.
    #[pyo3(signature = (qdot, dt_s=0.1))]
    fn command(&self, py: Python<'_>, qdot: Vec<f64>, dt_s: f64) -> PyResult<()> {
        self.call(py, Request::Command { qdot, dt_s }).map(|_| ())
    }

    /// Move the robot to joints `q` (rad) at once.
    fn set_joints(&self, py: Python<'_>, q: Vec<f64>) -> PyResult<()> {
        self.call(py, Request::SetJoints(q)).map(|_| ())
    }

    /// Start an episode again: the joints at `q` (default: the scenario's start), time and frame
    /// counter at 0; with `seed`, the image noise of every following frame is drawn from it, so
    /// the same `q` and `seed` replay the same observations.
    #[pyo3(signature = (q=None, seed=None))]
    fn reset(&self, py: Python<'_>, q: Option<Vec<f64>>, seed: Option<u64>) -> PyResult<()> {
        let q = q.unwrap_or_else(|| self.info.q_start_rad.clone());
        self.call(py, Request::Restart { q, seed }).map(|_| ())
    }

    /// The model's prediction: every feature's pixel with the robot at joints `q` ((N, 2), NaN
    /// where not visible), from the scenario's nominal cell (no rendering).
    fn project<'py>(&self, py: Python<'py>, q: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
        let Reply::Pixels(px) = self.call(py, Request::Project(q))? else { return Err(err("unexpected reply")) };
        optional_points_to_py(py, &px)
    }

    /// Stop the simulator thread (also done when the object is collected).
    fn close(&mut self) {
        self.jobs = None;
    }

    /// The scenario's fixed facts: `robot`, `dof`, `features`, `camera` (scene-file camera),
    /// `tool_from_cam` and `goal_cam_from_target` (4 x 4), `q_start_rad`.
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.info)
    }

    /// Number of joints.
    #[getter]
    fn dof(&self) -> usize {
        self.info.dof
    }

    fn __repr__(&self) -> String {
        format!("Sim(robot={:?}, dof={}, features={})", self.info.robot, self.info.dof, self.info.features)
    }
}
