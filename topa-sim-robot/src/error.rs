//! The simulated robot's errors: its sockets, the simulation, and a controller that never takes the robot.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(
        "simulated robot: socket {addr} (is another `topa sim-robot` or `topa control` using it? give another address)"
    )]
    Socket {
        addr: std::net::SocketAddr,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    #[error(transparent)]
    Eval(#[from] topa_eval::Error),
    #[error("simulated robot: the simulation diverged at t = {0:.3} s")]
    Diverged(f64),
    /// The controller did not take the robot (the message names the address it waited on and the fix).
    #[error("{0}")]
    NoController(String),
    #[error(transparent)]
    Control(#[from] topa_control::Error),
}

pub type Result<T> = std::result::Result<T, Error>;
