//! `--ros-args`, as rcl reads them for rclcpp and rclpy nodes, for our two
//! nodes (docs/ros_interface.md §6.2).
//!
//! Everything between `--ros-args` and `--` (or the end) is a ROS argument;
//! the rest goes to the node's own options. Understood:
//!
//! - `-r`/`--remap [node:]from:=to`: `__ns:=/ns` (the node's namespace),
//!   `__node:=name` (also `__name`), and topic and service names
//!   (`rostopic://` or `rosservice://` before `from` limits a rule to one kind);
//! - `-p`/`--param [node:]name:=value`, the value read as YAML (`500`,
//!   `1.5`, `true`, `abc`, `[1, 2]`);
//! - `--params-file FILE`: rcl's YAML (`node: ros__parameters: {...}`,
//!   namespaces as nested keys or in the key, `/**` and `*` wildcards);
//! - `--log-level [name:=]LEVEL` (debug, info, warn, error, fatal).
//!
//! rcl's other arguments (`--enclave`, `--log-config-file`, the
//! `--enable-/--disable-*-logs` flags, ...) are accepted with a warning
//! and do nothing; anything else is an error, as in rcl. Later rules win.

use crate::params_file::{read_params_file, yaml_value};
use ros2_client::ParameterValue;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU8, Ordering};

/// The command line cut in two: the program name with the node's own
/// arguments, and the ROS arguments.
#[derive(Debug, Default, PartialEq)]
pub struct Split {
    pub args: Vec<OsString>,
    pub ros: Vec<String>,
}

/// Cuts `--ros-args ... [--]` sections out of a command line (there may be
/// several). ROS arguments must be UTF-8.
pub fn split<I: IntoIterator<Item = OsString>>(all: I) -> Result<Split, String> {
    let mut s = Split::default();
    let mut in_ros = false;
    for a in all {
        if a == "--ros-args" {
            in_ros = true;
        } else if in_ros && a == "--" {
            in_ros = false;
        } else if in_ros {
            let a = a
                .into_string()
                .map_err(|a| format!("ROS argument {a:?} is not UTF-8"))?;
            s.ros.push(a);
        } else {
            s.args.push(a);
        }
    }
    Ok(s)
}

/// Which names a remap rule applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Any,
    Topic,
    Service,
}

/// `[node:]from:=to`.
#[derive(Clone, Debug, PartialEq)]
pub struct Remap {
    pub node: Option<String>,
    pub kind: Kind,
    pub from: String,
    pub to: String,
}

/// One ROS argument that matters, in command-line order.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    Remap(Remap),
    Param {
        node: Option<String>,
        name: String,
        value: ParameterValue,
        /// as given, for messages
        text: String,
    },
    ParamsFile(PathBuf),
}

/// rcutils' severities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Debug = 10,
    Info = 20,
    Warn = 30,
    Error = 40,
    Fatal = 50,
}

impl Level {
    pub fn parse(s: &str) -> Result<Level, String> {
        match s.to_ascii_lowercase().as_str() {
            "debug" => Ok(Level::Debug),
            "info" => Ok(Level::Info),
            "warn" | "warning" => Ok(Level::Warn),
            "error" => Ok(Level::Error),
            "fatal" => Ok(Level::Fatal),
            _ => Err(format!(
                "--log-level {s}: unknown level (debug, info, warn, error, fatal)"
            )),
        }
    }
}

static LEVEL: AtomicU8 = AtomicU8::new(Level::Info as u8);

/// Sets the process's log level (`--log-level`).
pub fn set_log_level(l: Level) {
    LEVEL.store(l as u8, Ordering::Relaxed);
}

/// Whether messages of level `l` are shown.
pub fn log_enabled(l: Level) -> bool {
    l as u8 >= LEVEL.load(Ordering::Relaxed)
}

/// The ROS arguments of a command line.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    pub items: Vec<Item>,
    pub log_level: Option<Level>,
    /// arguments accepted but not acted on
    pub warnings: Vec<String>,
}

/// rcl's arguments these nodes accept and ignore, and whether each takes a value.
const IGNORED: &[(&str, bool)] = &[
    ("-e", true),
    ("--enclave", true),
    ("--log-config-file", true),
    ("--log-file-name", true),
    ("--enable-rosout-logs", false),
    ("--disable-rosout-logs", false),
    ("--enable-stdout-logs", false),
    ("--disable-stdout-logs", false),
    ("--enable-external-lib-logs", false),
    ("--disable-external-lib-logs", false),
];

/// Parses the ROS arguments (those [`split`] found).
pub fn parse(ros: &[String]) -> Result<RosArgs, String> {
    let mut out = RosArgs::default();
    let mut it = ros.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("ROS argument {a} needs a value"))
        };
        match a.as_str() {
            "-r" | "--remap" => out.items.push(Item::Remap(parse_remap(&value()?)?)),
            "-p" | "--param" => {
                let v = value()?;
                let (node, name, value) = parse_param(&v)?;
                out.items.push(Item::Param {
                    node,
                    name,
                    value,
                    text: v,
                });
            }
            "--params-file" => out.items.push(Item::ParamsFile(PathBuf::from(value()?))),
            "--log-level" => {
                let v = value()?;
                // `LEVEL` or `logger:=LEVEL` (these nodes have one logger each)
                let level = v.rsplit_once(":=").map_or(v.as_str(), |(_, l)| l);
                out.log_level = Some(Level::parse(level)?);
            }
            other => match IGNORED.iter().find(|(n, _)| *n == other) {
                Some((n, takes)) => {
                    let shown = if *takes {
                        format!("{n} {}", value()?)
                    } else {
                        n.to_string()
                    };
                    out.warnings
                        .push(format!("ROS argument {shown} is not supported; ignored"));
                }
                None => {
                    return Err(format!(
                        "unknown ROS argument '{other}' (after --ros-args: -r/--remap FROM:=TO, \
                         -p/--param NAME:=VALUE, --params-file FILE, --log-level LEVEL; \
                         end them with --)"
                    ))
                }
            },
        }
    }
    Ok(out)
}

/// `[node:]lhs:=rhs` → (node, lhs, rhs).
fn split_rule<'a>(what: &str, s: &'a str) -> Result<(Option<&'a str>, &'a str, &'a str), String> {
    let Some((lhs, rhs)) = s.split_once(":=") else {
        return Err(format!("{what} '{s}': expected NAME:=VALUE"));
    };
    let (node, lhs) = match lhs.find(':') {
        Some(i) if !lhs[i..].starts_with("://") => (Some(&lhs[..i]), &lhs[i + 1..]),
        _ => (None, lhs),
    };
    if let Some(n) = node {
        check_token(n).map_err(|e| format!("{what} '{s}': node name '{n}': {e}"))?;
    }
    Ok((node, lhs, rhs))
}

fn parse_remap(s: &str) -> Result<Remap, String> {
    let (node, lhs, rhs) = split_rule("remap", s)?;
    let (kind, from) = if let Some(f) = lhs.strip_prefix("rostopic://") {
        (Kind::Topic, f)
    } else if let Some(f) = lhs.strip_prefix("rosservice://") {
        (Kind::Service, f)
    } else {
        (Kind::Any, lhs)
    };
    let bad = |e: String| format!("remap '{s}': {e}");
    match from {
        "__ns" => {
            check_namespace(rhs).map_err(bad)?;
        }
        "__node" | "__name" => check_token(rhs).map_err(bad)?,
        _ => {
            check_name(from).map_err(|e| bad(format!("'{from}': {e}")))?;
            check_name(rhs).map_err(|e| bad(format!("'{rhs}': {e}")))?;
        }
    }
    Ok(Remap {
        node: node.map(str::to_string),
        kind,
        from: from.to_string(),
        to: rhs.to_string(),
    })
}

fn parse_param(s: &str) -> Result<(Option<String>, String, ParameterValue), String> {
    let (node, name, v) = split_rule("parameter", s)?;
    check_param_name(name).map_err(|e| format!("parameter '{s}': {e}"))?;
    let value = yaml_value(v).map_err(|e| format!("parameter '{s}': {e}"))?;
    Ok((node.map(str::to_string), name.to_string(), value))
}

/// A name token: a letter or `_`, then letters, digits, `_`.
fn check_token(t: &str) -> Result<(), String> {
    let mut c = t.chars();
    match c.next() {
        None => Err("empty".into()),
        Some(f) if !(f.is_ascii_alphabetic() || f == '_') => {
            Err(format!("'{t}' must start with a letter or '_'"))
        }
        _ if !c.all(|x| x.is_ascii_alphanumeric() || x == '_') => {
            Err(format!("'{t}' may hold only letters, digits and '_'"))
        }
        _ => Ok(()),
    }
}

/// A namespace: `/` or `/tok/tok` (a relative one is made absolute).
fn check_namespace(ns: &str) -> Result<(), String> {
    let rel = ns.strip_prefix('/').unwrap_or(ns);
    if rel.is_empty() {
        return Ok(());
    }
    rel.split('/').try_for_each(check_token)
}

/// A topic or service name: tokens separated by `/`, absolute, relative or
/// private (`~`, `~/x`).
fn check_name(n: &str) -> Result<(), String> {
    let rest = if n == "~" {
        return Ok(());
    } else if let Some(r) = n.strip_prefix("~/") {
        r
    } else {
        n.strip_prefix('/').unwrap_or(n)
    };
    rest.split('/').try_for_each(check_token)
}

pub(crate) fn check_param_name(n: &str) -> Result<(), String> {
    n.split('.')
        .try_for_each(check_token)
        .map_err(|e| format!("name {e}"))
}

/// A parameter value from the command line or a file, for one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    pub name: String,
    pub value: ParameterValue,
    /// where it came from, for messages: `-p rate:=500`, `FILE (/**)`
    pub origin: String,
}

impl RosArgs {
    /// The remap rules for the node `name` (its name before any `__node`
    /// rule), `__ns` and `__node` rules left out.
    pub fn remaps(&self, name: &str) -> Vec<Remap> {
        self.remap_items(name)
            .filter(|r| !matches!(r.from.as_str(), "__ns" | "__node" | "__name"))
            .cloned()
            .collect()
    }

    fn remap_items<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Remap> + 'a {
        self.items.iter().filter_map(move |i| match i {
            Item::Remap(r) if r.node.as_deref().is_none_or(|n| n == name) => Some(r),
            _ => None,
        })
    }

    /// The node's name: the last `__node` rule for it, else `default`.
    pub fn node_name(&self, default: &str) -> String {
        self.remap_items(default)
            .filter(|r| r.from == "__node" || r.from == "__name")
            .last()
            .map_or_else(|| default.to_string(), |r| r.to.clone())
    }

    /// The node's namespace from the last `__ns` rule for it (absolute).
    pub fn namespace(&self, name: &str) -> Option<String> {
        self.remap_items(name)
            .filter(|r| r.from == "__ns")
            .last()
            .map(|r| absolute(&r.to))
    }

    /// The parameter values for the node `fqn` (named `name` before any
    /// `__node` rule), in the order they apply (a later one wins): each
    /// `-p` and each `--params-file` where it stands, a file's sections
    /// that match the node in file order (as rclcpp). Files that
    /// cannot be read or parsed are errors; sections that look meant for
    /// this node but do not match it come back as warnings.
    pub fn overrides(&self, name: &str, fqn: &str) -> Result<(Vec<Override>, Vec<String>), String> {
        let own = fqn.rsplit('/').next().unwrap_or(fqn);
        let mut out = Vec::new();
        let mut warn = Vec::new();
        for i in &self.items {
            match i {
                Item::Param {
                    node,
                    name: p,
                    value,
                    text,
                } => {
                    if node.as_deref().is_none_or(|n| n == name || n == own) {
                        out.push(Override {
                            name: p.clone(),
                            value: value.clone(),
                            origin: format!("-p {text}"),
                        });
                    }
                }
                Item::ParamsFile(f) => {
                    let sections = read_params_file(f)?;
                    let shown = f.display();
                    for (key, params) in sections {
                        if crate::params_file::node_matches(&key, fqn) {
                            out.extend(params.into_iter().map(|(n, v)| Override {
                                name: n,
                                value: v,
                                origin: format!("{shown} ({key})"),
                            }));
                        } else if key.rsplit('/').next() == Some(own) {
                            warn.push(format!(
                                "{shown}: section '{key}' is not for this node {fqn} \
                                 (a key is a full node name: write '{fqn}:' or '/**/{own}:')"
                            ));
                        }
                    }
                }
                Item::Remap(_) => {}
            }
        }
        Ok((out, warn))
    }
}

/// `ns` made absolute, without a trailing `/` (unless it is `/`).
pub fn absolute(ns: &str) -> String {
    let t = ns.trim_matches('/');
    format!("/{t}")
}

/// `name` resolved in the namespace `ns` of the node `fqn`: absolute names
/// as they are, `~` and `~/x` under the node's name, others under `ns`.
pub fn resolve(name: &str, ns: &str, fqn: &str) -> String {
    if name == "~" {
        fqn.to_string()
    } else if let Some(r) = name.strip_prefix("~/") {
        format!("{fqn}/{r}")
    } else if name.starts_with('/') {
        name.to_string()
    } else if ns == "/" {
        format!("/{name}")
    } else {
        format!("{ns}/{name}")
    }
}

/// Topic and service remapping for one node: rules with their names
/// resolved in the node's namespace.
#[derive(Clone, Debug, Default)]
pub struct Remapper {
    rules: Vec<(Kind, String, String)>,
}

impl Remapper {
    /// The rules of `remaps` for the node `fqn` in the namespace `ns`.
    pub fn new(remaps: &[Remap], ns: &str, fqn: &str) -> Remapper {
        Remapper {
            rules: remaps
                .iter()
                .map(|r| (r.kind, resolve(&r.from, ns, fqn), resolve(&r.to, ns, fqn)))
                .collect(),
        }
    }

    /// What the fully qualified name `full` of a topic (`service` false)
    /// or service becomes: the first rule that matches, as rcl.
    pub fn apply(&self, full: &str, service: bool) -> Option<&str> {
        self.rules
            .iter()
            .find(|(k, from, _)| {
                from == full
                    && match k {
                        Kind::Any => true,
                        Kind::Topic => !service,
                        Kind::Service => service,
                    }
            })
            .map(|(_, _, to)| to.as_str())
    }

    pub fn is_empty(&self) -> bool {
        self.rules.is_empty()
    }
}

/// What a node takes from its `--ros-args` at start: its name and
/// namespace, the remap rules (in force from here on for the topics and
/// services of [`crate::ros`]), the log level, and the parameter values
/// meant for it.
#[derive(Debug)]
pub struct Startup {
    pub name: String,
    pub namespace: String,
    pub fqn: String,
    pub overrides: Vec<Override>,
    /// the program's name, for messages
    pub tag: String,
}

impl Startup {
    /// From the ROS arguments [`split`] found, for the node named `name`
    /// by default whose own options gave the namespace `namespace`
    /// (`__ns` wins). Warnings go to stderr as `tag: warning: ...`.
    pub fn new(ros: &[String], name: &str, namespace: &str, tag: &str) -> Result<Startup, String> {
        let args = parse(ros)?;
        if let Some(l) = args.log_level {
            set_log_level(l);
        }
        let node = args.node_name(name);
        let ns = match args.namespace(name) {
            Some(ns) => ns,
            None => {
                check_namespace(namespace).map_err(|e| format!("namespace '{namespace}': {e}"))?;
                absolute(namespace)
            }
        };
        let fqn = resolve(&node, &ns, "/");
        let (overrides, file_warnings) = args.overrides(name, &fqn)?;
        for w in args.warnings.iter().chain(&file_warnings) {
            if log_enabled(Level::Warn) {
                eprintln!("{tag}: warning: {w}");
            }
        }
        crate::ros::set_remaps(Remapper::new(&args.remaps(name), &ns, &fqn));
        Ok(Startup {
            name: node,
            namespace: ns,
            fqn,
            overrides,
            tag: tag.to_string(),
        })
    }

    /// Puts the parameter values meant for this node into `params` (later
    /// ones win). A value of the wrong type or out of range is an error
    /// naming where it came from; a name the node does not have is a
    /// warning (as rclcpp, which ignores it). `given(name)` is the
    /// node's own option for the parameter when it was given on the
    /// command line too: the ROS parameter wins, with a warning.
    pub fn apply(
        &self,
        params: &mut [crate::params::Param],
        given: impl Fn(&str) -> Option<String>,
    ) -> Result<(), String> {
        for o in &self.overrides {
            let Some(p) = params.iter_mut().find(|p| p.name == o.name) else {
                let sim_time = o.name == "use_sim_time";
                if log_enabled(Level::Warn) && sim_time && o.value != ParameterValue::Boolean(false)
                {
                    eprintln!(
                        "{}: warning: {}: simulated time is not supported (the node stamps with the system clock); ignored",
                        self.tag, o.origin
                    );
                } else if log_enabled(Level::Warn) && !sim_time {
                    eprintln!(
                        "{}: warning: {} is not a parameter of this node; ignored",
                        self.tag, o.origin
                    );
                }
                continue;
            };
            p.value = p
                .coerce(&o.value)
                .map_err(|e| format!("{e} (from {})", o.origin))?;
            if let Some(opt) = given(&o.name) {
                if log_enabled(Level::Warn) {
                    eprintln!(
                        "{}: warning: {opt} and {} both set {}: the ROS parameter wins ({})",
                        self.tag,
                        o.origin,
                        o.name,
                        crate::params::show(&p.value)
                    );
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn os(v: &[&str]) -> Vec<OsString> {
        v.iter().map(OsString::from).collect()
    }

    fn args(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn ros_args_are_cut_out_of_the_command_line() {
        let s = split(os(&[
            "cnc_node",
            "--rate",
            "500",
            "--ros-args",
            "-r",
            "__ns:=/m2",
            "--",
            "--record-all",
            "--ros-args",
            "-p",
            "x:=1",
        ]))
        .unwrap();
        assert_eq!(s.args, os(&["cnc_node", "--rate", "500", "--record-all"]));
        assert_eq!(s.ros, args(&["-r", "__ns:=/m2", "-p", "x:=1"]));
    }

    #[test]
    fn remaps_params_and_levels_parse() {
        let r = parse(&args(&[
            "-r",
            "__ns:=/m2",
            "--remap",
            "cnc_node:__node:=ctl",
            "-r",
            "rostopic://status:=/other/status",
            "-p",
            "rate:=500",
            "--param",
            "cnc_node:record_dir:=/tmp/r",
            "-p",
            "list:=[1, 2.5]",
            "--log-level",
            "WARN",
            "--enclave",
            "/e",
            "--disable-rosout-logs",
        ]))
        .unwrap();
        assert_eq!(r.namespace("cnc_node").as_deref(), Some("/m2"));
        assert_eq!(r.node_name("cnc_node"), "ctl");
        assert_eq!(r.node_name("sim_axes"), "sim_axes");
        assert_eq!(r.log_level, Some(Level::Warn));
        assert_eq!(r.warnings.len(), 2, "{:?}", r.warnings);
        let rm = r.remaps("cnc_node");
        assert_eq!(rm.len(), 1);
        assert_eq!(rm[0].kind, Kind::Topic);
        let (o, w) = r.overrides("cnc_node", "/m2/ctl").unwrap();
        assert!(w.is_empty());
        assert_eq!(o[0].value, ParameterValue::Integer(500));
        assert_eq!(o[1].value, ParameterValue::String("/tmp/r".into()));
        assert_eq!(o[2].value, ParameterValue::DoubleArray(vec![1.0, 2.5]));
        // a rule for another node is not this one's
        let (o, _) = r.overrides("sim_axes", "/m2/sim_axes").unwrap();
        assert_eq!(o.len(), 2);
    }

    #[test]
    fn bad_ros_args_are_refused_with_the_reason() {
        for (a, want) in [
            (&["--bogus"][..], "unknown ROS argument '--bogus'"),
            (&["-r"][..], "needs a value"),
            (&["-r", "nothing"][..], "expected NAME:=VALUE"),
            (&["-r", "__ns:=/1x"][..], "must start with a letter"),
            (&["-r", "__node:=a/b"][..], "only letters"),
            (&["-p", "9x:=1"][..], "must start with a letter"),
            (&["-p", "x:={a: 1}"][..], "mapping"),
            (&["-p", "x:=[1, a]"][..], "one type"),
            (&["--log-level", "loud"][..], "unknown level"),
        ] {
            let e = parse(&args(a)).unwrap_err();
            assert!(e.contains(want), "{a:?}: {e}");
        }
    }

    #[test]
    fn params_files_match_the_node_by_its_full_name() {
        let dir = std::env::temp_dir().join(format!("ros_args_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("p.yaml");
        std::fs::write(
            &f,
            "/**:\n  ros__parameters:\n    machine: lathe\n    rate: 100\n\
             /m2/cnc_node:\n  ros__parameters:\n    rate: 500\n    nested:\n      a: 1.5\n\
             cnc_node:\n  ros__parameters:\n    rate: 7\n\
             /m2:\n  sim_axes:\n    ros__parameters:\n      seed: 3\n",
        )
        .unwrap();
        let r = parse(&args(&[
            "--params-file",
            f.to_str().unwrap(),
            "-p",
            "rate:=600",
        ]))
        .unwrap();
        let (o, w) = r.overrides("cnc_node", "/m2/cnc_node").unwrap();
        let got: Vec<(&str, &ParameterValue)> =
            o.iter().map(|o| (o.name.as_str(), &o.value)).collect();
        assert_eq!(
            got,
            [
                ("machine", &ParameterValue::String("lathe".into())),
                ("rate", &ParameterValue::Integer(100)),
                ("rate", &ParameterValue::Integer(500)),
                ("nested.a", &ParameterValue::Double(1.5)),
                ("rate", &ParameterValue::Integer(600)),
            ]
        );
        // `cnc_node:` is the node /cnc_node, not /m2/cnc_node: said so
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("'/cnc_node' is not for this node /m2/cnc_node"),
            "{w:?}"
        );
        let (o, _) = r.overrides("sim_axes", "/m2/sim_axes").unwrap();
        assert_eq!(o.iter().filter(|o| o.name == "seed").count(), 1);
        // errors name the file
        std::fs::write(&f, "cnc_node:\n  ros__parameters: [1]\n").unwrap();
        let e = r.overrides("cnc_node", "/cnc_node").unwrap_err();
        assert!(
            e.contains("p.yaml") && e.contains("mapping of parameter names"),
            "{e}"
        );
        std::fs::write(&f, "a: [").unwrap();
        assert!(r
            .overrides("cnc_node", "/cnc_node")
            .unwrap_err()
            .contains("not YAML"));
        let r = parse(&args(&["--params-file", "/nonexistent/p.yaml"])).unwrap();
        assert!(r
            .overrides("x", "/x")
            .unwrap_err()
            .contains("/nonexistent/p.yaml"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn names_resolve_and_remap() {
        assert_eq!(resolve("status", "/m2", "/m2/cnc_node"), "/m2/status");
        assert_eq!(resolve("status", "/", "/cnc_node"), "/status");
        assert_eq!(resolve("~/x", "/m2", "/m2/cnc_node"), "/m2/cnc_node/x");
        assert_eq!(resolve("/a/b", "/m2", "/m2/n"), "/a/b");
        let r = parse(&args(&[
            "-r",
            "joint_setpoints:=/bus/setpoints",
            "-r",
            "rosservice://abort:=stop",
            "-r",
            "other_node:status:=/x",
        ]))
        .unwrap();
        let m = Remapper::new(&r.remaps("cnc_node"), "/m2", "/m2/cnc_node");
        assert_eq!(
            m.apply("/m2/joint_setpoints", false),
            Some("/bus/setpoints")
        );
        assert_eq!(m.apply("/m2/abort", true), Some("/m2/stop"));
        assert_eq!(m.apply("/m2/abort", false), None);
        assert_eq!(m.apply("/m2/status", false), None);
        assert_eq!(absolute("m2/"), "/m2");
        assert_eq!(absolute("/"), "/");
    }
}
