//! A node's command line: its own options (clap) with its `--ros-args`
//! over them, and the ROS parameters both make (docs/ros_interface.md
//! §6.2). Each node says which parameters its options are ([`Options`]).

use crate::params::Param;
use crate::ros_args::{split, Startup};
use clap::parser::ValueSource;
use std::ffi::OsString;

/// A node's options, as ROS parameters.
pub trait Options: clap::Parser {
    /// The node's name unless `__node` says otherwise.
    const NODE: &'static str;
    /// Its `--namespace` option (`__ns` wins).
    fn namespace_mut(&mut self) -> &mut String;
    /// The parameters with the options' values (unset where the machine
    /// file decides), named as the options: `--foo-bar` is `foo_bar`.
    fn declare(&self) -> Vec<Param>;
    /// The parameters' values back into the options.
    fn read_back(&mut self, params: &[Param]);
}

/// A node's settings at start.
#[derive(Debug)]
pub struct Setup<A> {
    pub args: A,
    pub start: Startup,
    /// the parameters with the values of the options and the ROS arguments
    pub params: Vec<Param>,
}

/// The settings from a command line (its first item the program's name):
/// the options, then the ROS arguments over them (with a warning for a
/// value given both ways). A bad value is an error; clap's own errors,
/// `--help` and `--version` exit here as usual.
pub fn setup<A: Options, I: IntoIterator<Item = OsString>>(argv: I) -> Result<Setup<A>, String> {
    let split = split(argv)?;
    let m = A::command()
        .try_get_matches_from(&split.args)
        .unwrap_or_else(|e| e.exit());
    let mut args = A::from_arg_matches(&m).map_err(|e| e.to_string())?;
    let ns = args.namespace_mut().clone();
    let start = Startup::new(&split.ros, A::NODE, &ns, A::NODE)?;
    *args.namespace_mut() = start.namespace.clone();
    let mut params = args.declare();
    // the options' own values must be in range too
    for p in &params {
        if !matches!(p.value, ros2_client::ParameterValue::NotSet) {
            p.coerce(&p.value)
                .map_err(|e| format!("--{}: {e}", p.name.replace('_', "-")))?;
        }
    }
    let ids: Vec<String> = A::command()
        .get_arguments()
        .map(|a| a.get_id().to_string())
        .collect();
    start.apply(&mut params, |name| {
        (ids.iter().any(|i| i == name) && m.value_source(name) == Some(ValueSource::CommandLine))
            .then(|| format!("--{}", name.replace('_', "-")))
    })?;
    args.read_back(&params);
    Ok(Setup {
        args,
        start,
        params,
    })
}
