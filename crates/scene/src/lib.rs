//! haptic6d's offline side, around the real-time [`engine`]: scene files and built-in scenes,
//! sphere-trees built from meshes and cached, device trajectories, the run loop, reports.
//!
//! Entry points:
//! - [`SceneSpec`] / [`Scene`]: the TOML scene file and the loaded scene (trees in mm);
//!   [`Scene::engine`] makes its [`engine::Engine`]; [`scenes::builtin`] gives the built-in
//!   `bunny`, `spline`, `plate`, `spline-tight` and `probe` scenes.
//! - [`cache::TreeCache`]: trees built from meshes, cached on disk by content hash.
//! - [`device::Device`]: trajectory replay and scripted motion.
//! - [`rt::run_loop`]: the haptic loop of `haptic6d run` on a named thread (one
//!   [`engine::Engine::step`] per frame), with deadline and jitter stats.
//! - [`trajectory::Trajectory`]: the `t,x,y,z,gamma,beta,alpha` CSV and keyframe scripts.
//! - [`report`]: `frames.csv` and the run summary.
#![warn(missing_docs)]
// Index loops over the 6 coordinates read like the maths they implement.
#![allow(clippy::needless_range_loop)]
#![cfg_attr(not(test), warn(clippy::unwrap_used, clippy::expect_used))]

pub mod cache;
pub mod device;
pub mod io;
pub mod report;
pub mod rt;
mod scene;
pub mod scenes;
pub mod stability;
pub mod stats;
pub mod trajectory;

pub use scene::{
    grouped, load_scene_file, mesh_triangles_line, object_tree_for_mesh, scale_tree, tree_for_mesh,
    BodySpec, Coupling, DeviceSpec, FrictionSpec, Goal, Motion, Scene, SceneSpec, SolverSpec,
    TreeParams,
};

/// Errors of the scene crate. Each message says what to fix; a wrapped cause is kept as the
/// [`std::error::Error::source`] (print the chain, e.g. anyhow's `{:#}`, for the whole story).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read or written.
    #[error("{path}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        #[source]
        source: std::io::Error,
    },
    /// A trajectory CSV is malformed.
    #[error("{file}:{line}: {msg}")]
    Trajectory {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong and what is expected.
        msg: String,
    },
    /// A scene file is malformed or names something that cannot be loaded.
    #[error("{file}: {msg}")]
    Scene {
        /// The scene file (or built-in scene name).
        file: String,
        /// What is wrong and what is expected (without the cause's own text).
        msg: String,
        /// The underlying error (a TOML, mesh, tree, setting or IO error), kept whole.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// An unknown built-in scene or solver name.
    #[error("unknown {what} `{name}`; expected one of: {expected}")]
    Unknown {
        /// What kind of name (scene, solver).
        what: &'static str,
        /// The name given.
        name: String,
        /// The accepted names.
        expected: String,
    },
    /// A setting (given through the Rust API) is outside its range; scene files report the
    /// same error inside [`SceneError::Scene`].
    #[error("{0}")]
    Setting(#[from] engine::config::SettingError),
    /// The haptic thread could not be started.
    #[error("cannot start the haptic thread `haptic6d-rt`")]
    ThreadStart(#[source] std::io::Error),
    /// The haptic thread panicked (a bug: the frame is written not to).
    #[error("the haptic thread `haptic6d-rt` panicked")]
    ThreadPanicked,
    /// The engine refused the scene (a tree it cannot use, a start in collision).
    #[error("{file}")]
    Engine {
        /// The scene file (or built-in scene name).
        file: String,
        /// What the engine said.
        #[source]
        source: engine::EngineError,
    },
}

/// An error and its sources on one line, `outer: inner: innermost`, as the command line prints
/// them (every door that shows a [`SceneError`] or an [`engine::EngineError`] as text uses it).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    std::iter::successors(Some(e), |e| e.source())
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(": ")
}

impl SceneError {
    /// A scene error of `file` with no underlying cause.
    pub fn scene(file: impl Into<String>, msg: impl Into<String>) -> Self {
        Self::Scene {
            file: file.into(),
            msg: msg.into(),
            source: None,
        }
    }

    /// A scene error of `file` caused by `source`: `msg` says what was being done (the
    /// cause's own text comes from the chain).
    pub fn caused(
        file: impl Into<String>,
        msg: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        Self::Scene {
            file: file.into(),
            msg: msg.into(),
            source: Some(Box::new(source)),
        }
    }
}
