//! A node's ROS parameters, served as rclcpp serves them: the six
//! `rcl_interfaces` services under the node's name (`ros2 param list`,
//! `get`, `set`, `describe`, `dump`) and `/parameter_events`.
//!
//! ros2-client has parameter services of its own, but their descriptors
//! say nothing (no description, never read-only, no range); these say
//! what each parameter is and which ones can change while the node runs.
//! A set is checked in this order, and a refusal says why: the name is
//! declared, the parameter is not read-only, the type is right (an integer
//! for a double parameter is taken), the range, then the node's own check.
//! Accepted changes go to the node through a channel.

use crate::ros_args::{log_enabled, Level};
use ros2_client::parameters::raw;
use ros2_client::rcl_interfaces as rcl;
use ros2_client::{Context, Node, ParameterValue};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex};

/// The type of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Bool,
    Integer,
    Double,
    String,
    /// a list of integers (`[0, 1]`); a single integer or a string such
    /// as `0,1` is taken for one
    IntegerArray,
}

impl Kind {
    fn raw(self) -> u8 {
        match self {
            Kind::Bool => raw::ParameterType::BOOL,
            Kind::Integer => raw::ParameterType::INTEGER,
            Kind::Double => raw::ParameterType::DOUBLE,
            Kind::String => raw::ParameterType::STRING,
            Kind::IntegerArray => raw::ParameterType::INTEGER_ARRAY,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Bool => "a bool",
            Kind::Integer => "an integer",
            Kind::Double => "a double",
            Kind::String => "a string",
            Kind::IntegerArray => "an integer array",
        }
    }
}

/// One declared parameter.
#[derive(Clone, Debug)]
pub struct Param {
    pub name: &'static str,
    pub kind: Kind,
    pub value: ParameterValue,
    pub description: String,
    /// what the range does not say (shown by `ros2 param describe`)
    pub constraints: String,
    pub read_only: bool,
    /// inclusive bounds of an integer or double parameter
    pub range: Option<(f64, f64)>,
}

impl Param {
    /// A read-only parameter.
    pub fn fixed(name: &'static str, kind: Kind, description: &str) -> Param {
        Param {
            name,
            kind,
            value: ParameterValue::NotSet,
            description: description.to_string(),
            constraints: "read-only: given at start".to_string(),
            read_only: true,
            range: None,
        }
    }

    /// A parameter `ros2 param set` can change while the node runs.
    pub fn live(name: &'static str, kind: Kind, description: &str) -> Param {
        Param {
            constraints: String::new(),
            read_only: false,
            ..Param::fixed(name, kind, description)
        }
    }

    pub fn range(mut self, lo: f64, hi: f64) -> Param {
        self.range = Some((lo, hi));
        self
    }

    pub fn constraints(mut self, c: &str) -> Param {
        self.constraints = c.to_string();
        self
    }

    pub fn value(mut self, v: ParameterValue) -> Param {
        self.value = v;
        self
    }

    /// `v` as this parameter's type, in its range: an integer is taken for
    /// a double, a whole double for an integer, `yes`/`no`/`on`/`off` for a
    /// bool (as rcl reads them).
    pub fn coerce(&self, v: &ParameterValue) -> Result<ParameterValue, String> {
        use ParameterValue as V;
        let n = self.name;
        let wrong = || {
            format!(
                "parameter '{n}' is {}, not {}",
                self.kind.name(),
                describe_value(v)
            )
        };
        let out = match (self.kind, v) {
            (Kind::Bool, V::Boolean(b)) => V::Boolean(*b),
            (Kind::Bool, V::String(s)) => match s.to_ascii_lowercase().as_str() {
                "true" | "yes" | "on" => V::Boolean(true),
                "false" | "no" | "off" => V::Boolean(false),
                _ => return Err(wrong()),
            },
            (Kind::Integer, V::Integer(i)) => V::Integer(*i),
            (Kind::Integer, V::Double(d)) if d.fract() == 0.0 && d.abs() < 9.0e15 => {
                V::Integer(*d as i64)
            }
            (Kind::Double, V::Double(d)) => V::Double(*d),
            (Kind::Double, V::Integer(i)) => V::Double(*i as f64),
            (Kind::String, V::String(s)) => V::String(s.clone()),
            (Kind::IntegerArray, V::IntegerArray(a)) => V::IntegerArray(a.clone()),
            (Kind::IntegerArray, V::Integer(i)) => V::IntegerArray(vec![*i]),
            // (`[]` reads as an empty string array)
            (Kind::IntegerArray, V::StringArray(a)) if a.is_empty() => V::IntegerArray(Vec::new()),
            (Kind::IntegerArray, V::String(s)) => {
                let mut a = Vec::new();
                for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
                    a.push(part.parse::<i64>().map_err(|_| wrong())?);
                }
                V::IntegerArray(a)
            }
            _ => return Err(wrong()),
        };
        if let Some((lo, hi)) = self.range {
            let xs: Vec<f64> = match &out {
                V::Integer(i) => vec![*i as f64],
                V::Double(d) => vec![*d],
                V::IntegerArray(a) => a.iter().map(|&i| i as f64).collect(),
                _ => Vec::new(),
            };
            if let Some(x) = xs
                .iter()
                .find(|x| !(x.is_finite() && (lo..=hi).contains(*x)))
            {
                let what = match &out {
                    V::IntegerArray(_) => format!("{x}"),
                    _ => show(&out),
                };
                return Err(format!(
                    "parameter '{n}': {what} is out of its range {lo} to {hi}"
                ));
            }
        }
        Ok(out)
    }
}

/// A value as `ros2 param get` would show it.
pub fn show(v: &ParameterValue) -> String {
    use ParameterValue as V;
    match v {
        V::NotSet => "(not set)".into(),
        V::Boolean(b) => b.to_string(),
        V::Integer(i) => i.to_string(),
        V::Double(d) => format!("{d:?}"),
        V::String(s) => format!("'{s}'"),
        V::ByteArray(a) => format!("{a:?}"),
        V::BooleanArray(a) => format!("{a:?}"),
        V::IntegerArray(a) => format!("{a:?}"),
        V::DoubleArray(a) => format!("{a:?}"),
        V::StringArray(a) => format!("{a:?}"),
    }
}

fn describe_value(v: &ParameterValue) -> String {
    use ParameterValue as V;
    let kind = match v {
        V::NotSet => return "unset".into(),
        V::Boolean(_) => "a bool",
        V::Integer(_) => "an integer",
        V::Double(_) => "a double",
        V::String(_) => "a string",
        _ => "a list",
    };
    format!("{kind} ({})", show(v))
}

/// The node's own check of a value (after type and range), e.g. that a
/// directory can be written.
pub type Check = Box<dyn Fn(&str, &ParameterValue) -> Result<(), String> + Send + Sync>;

/// A change `ros2 param set` made: (name, new value).
pub type Change = (String, ParameterValue);

struct Inner {
    fqn: String,
    /// the program's name, for log lines
    tag: String,
    params: Mutex<Vec<Param>>,
    check: Check,
    changes: Mutex<Sender<Change>>,
    events: Mutex<ros2_client::Publisher<raw::ParameterEvent>>,
}

/// A node's parameters and their services (cheap to clone).
#[derive(Clone)]
pub struct Parameters {
    inner: Arc<Inner>,
}

struct Servers {
    get: ros2_client::Server<rcl::GetParametersRequest, rcl::GetParametersResponse>,
    types: ros2_client::Server<rcl::GetParameterTypesRequest, rcl::GetParameterTypesResponse>,
    set: ros2_client::Server<rcl::SetParametersRequest, rcl::SetParametersResponse>,
    atomic: ros2_client::Server<rcl::SetParametersRequest, rcl::SetParametersAtomicallyResponse>,
    list: ros2_client::Server<rcl::ListParametersRequest, rcl::ListParametersResponse>,
    describe: ros2_client::Server<rcl::DescribeParametersRequest, rcl::DescribeParametersResponse>,
}

fn server<Req, Resp>(
    node: &mut Node,
    fqn: &str,
    base: &str,
    ty: &str,
) -> Result<ros2_client::Server<Req, Resp>, String>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let q = crate::ros::qos_services();
    let name =
        ros2_client::Name::new(fqn, base).map_err(|e| format!("service {fqn}/{base}: {e:?}"))?;
    node.create_server::<Req, Resp>(
        ros2_client::ServiceMapping::Enhanced,
        &name,
        &ros2_client::ServiceTypeName::new("rcl_interfaces", ty),
        q.clone(),
        q,
    )
    .map_err(|e| format!("service {fqn}/{base}: {e:?}"))
}

impl Parameters {
    /// Declares `params` (with their values) on `node` and serves them on a
    /// thread of their own. The node must be made without ros2-client's
    /// parameter services ([`crate::ros::join_with`] with
    /// `start_parameter_services(false)`). `use_sim_time` is added: every
    /// ROS node has it; these nodes run on the system clock, so only
    /// `false` is taken. Accepted sets come out of the receiver.
    pub fn serve(
        ctx: &Context,
        node: &mut Node,
        tag: &str,
        mut params: Vec<Param>,
        check: Check,
    ) -> Result<(Parameters, Receiver<Change>), String> {
        let fqn = node.fully_qualified_name();
        params.push(
            Param::live(
                "use_sim_time",
                Kind::Bool,
                "simulated time (/clock): not supported, the node stamps with the system clock",
            )
            .constraints("false only")
            .value(ParameterValue::Boolean(false)),
        );
        let servers = Servers {
            get: server(node, &fqn, "get_parameters", "GetParameters")?,
            types: server(node, &fqn, "get_parameter_types", "GetParameterTypes")?,
            set: server(node, &fqn, "set_parameters", "SetParameters")?,
            atomic: server(
                node,
                &fqn,
                "set_parameters_atomically",
                "SetParametersAtomically",
            )?,
            list: server(node, &fqn, "list_parameters", "ListParameters")?,
            describe: server(node, &fqn, "describe_parameters", "DescribeParameters")?,
        };
        let events = node
            .create_publisher::<raw::ParameterEvent>(&ctx.get_parameter_events_topic(), None)
            .map_err(|e| format!("/parameter_events: {e:?}"))?;
        let (tx, rx) = mpsc::channel();
        let p = Parameters {
            inner: Arc::new(Inner {
                fqn,
                tag: tag.to_string(),
                params: Mutex::new(params),
                check,
                changes: Mutex::new(tx),
                events: Mutex::new(events),
            }),
        };
        let declared: Vec<raw::Parameter> = p
            .lock()
            .iter()
            .map(|q| raw::Parameter {
                name: q.name.to_string(),
                value: q.value.clone().into(),
            })
            .collect();
        p.publish(declared, Vec::new());
        let me = p.clone();
        std::thread::Builder::new()
            .name("ros-params".into())
            .spawn(move || me.run(servers))
            .map_err(|e| e.to_string())?;
        Ok((p, rx))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Param>> {
        // a panic elsewhere while holding it leaves the values as they were
        self.inner.params.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The value of `name` (None if not declared).
    pub fn get(&self, name: &str) -> Option<ParameterValue> {
        self.lock()
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.value.clone())
    }

    /// Sets `name` from the node itself (a change made another way, e.g. a
    /// service): checked like a remote set, read-only or not; the node is
    /// not told (it made the change).
    pub fn set_local(&self, name: &str, v: ParameterValue) -> Result<(), String> {
        self.set_many(&[(name.to_string(), v)], false, false)
    }

    /// The checks of a set, then the values stored, the event published
    /// and (`notify`) the node told; all or nothing.
    fn set_many(
        &self,
        sets: &[(String, ParameterValue)],
        remote: bool,
        notify: bool,
    ) -> Result<(), String> {
        let mut checked = Vec::with_capacity(sets.len());
        {
            let params = self.lock();
            for (name, v) in sets {
                let Some(p) = params.iter().find(|p| p.name == name) else {
                    return Err(format!(
                        "parameter '{name}' is not declared by this node (ros2 param list shows its parameters)"
                    ));
                };
                if matches!(v, ParameterValue::NotSet) {
                    return Err(format!("parameter '{name}' cannot be unset"));
                }
                if remote && p.read_only {
                    return Err(format!(
                        "parameter '{name}' cannot be set because it is read-only: give it at start (--ros-args -p {name}:=VALUE)"
                    ));
                }
                let v = p.coerce(v)?;
                if name == "use_sim_time" {
                    if v == ParameterValue::Boolean(true) {
                        return Err("use_sim_time: this node runs on the system clock (its stamps are the wall clock's); simulated time is not supported".into());
                    }
                } else {
                    (self.inner.check)(name, &v)?;
                }
                checked.push((p.name, p.value.clone(), v));
            }
        }
        let mut changed = Vec::new();
        {
            let mut params = self.lock();
            for (name, old, v) in &checked {
                if let Some(p) = params.iter_mut().find(|p| p.name == *name) {
                    p.value = v.clone();
                }
                changed.push(raw::Parameter {
                    name: name.to_string(),
                    value: v.clone().into(),
                });
                if remote && log_enabled(Level::Info) {
                    eprintln!(
                        "{}: parameter {name}: {} -> {}",
                        self.inner.tag,
                        show(old),
                        show(v)
                    );
                }
            }
        }
        self.publish(Vec::new(), changed);
        if notify {
            let tx = self.inner.changes.lock().unwrap_or_else(|e| e.into_inner());
            for (name, _, v) in checked {
                let _ = tx.send((name.to_string(), v));
            }
        }
        Ok(())
    }

    fn publish(&self, new: Vec<raw::Parameter>, changed: Vec<raw::Parameter>) {
        let ev = raw::ParameterEvent {
            stamp: ros2_client::builtin_interfaces::Time::now(),
            node: self.inner.fqn.clone(),
            new_parameters: new,
            changed_parameters: changed,
            deleted_parameters: Vec::new(),
        };
        let w = self.inner.events.lock().unwrap_or_else(|e| e.into_inner());
        let _ = w.publish(ev);
    }

    /// `f` of each named parameter, or `missing` for a name not declared.
    fn each<T>(&self, names: &[String], missing: T, f: impl Fn(&Param) -> T) -> Vec<T>
    where
        T: Clone,
    {
        let params = self.lock();
        names
            .iter()
            .map(|n| {
                params
                    .iter()
                    .find(|p| p.name == n)
                    .map_or_else(|| missing.clone(), &f)
            })
            .collect()
    }

    fn values(&self, names: &[String]) -> Vec<raw::ParameterValue> {
        self.each(names, ParameterValue::NotSet.into(), |p| {
            p.value.clone().into()
        })
    }

    fn types(&self, names: &[String]) -> Vec<u8> {
        self.each(names, raw::ParameterType::NOT_SET, |p| p.kind.raw())
    }

    /// As rclcpp: without prefixes, the names with fewer than `depth` dots
    /// (0: all); else those equal to a prefix or under `prefix.`.
    fn list(&self, prefixes: &[String], depth: u64) -> rcl::ListParametersResult {
        let within = |s: &str| depth == 0 || (s.matches('.').count() as u64) < depth;
        let mut r = rcl::ListParametersResult {
            names: Vec::new(),
            prefixes: Vec::new(),
        };
        for p in self.lock().iter() {
            let n = p.name;
            let hit = (prefixes.is_empty() && within(n))
                || prefixes.iter().any(|pre| {
                    n == pre
                        || n.strip_prefix(pre.as_str())
                            .and_then(|r| r.strip_prefix('.'))
                            .is_some_and(|r| within(&format!(".{r}")))
                });
            if hit {
                r.names.push(n.to_string());
                if let Some((ns, _)) = n.rsplit_once('.') {
                    if !r.prefixes.iter().any(|x| x == ns) {
                        r.prefixes.push(ns.to_string());
                    }
                }
            }
        }
        r
    }

    fn describe(&self, names: &[String]) -> Vec<raw::ParameterDescriptor> {
        let params = self.lock();
        names
            .iter()
            .map(|n| match params.iter().find(|p| p.name == n) {
                Some(p) => {
                    let (mut floating_point_range, mut integer_range) = (Vec::new(), Vec::new());
                    match (p.kind, p.range) {
                        (Kind::Double, Some((from_value, to_value))) => {
                            floating_point_range.push(raw::FloatingPointRange {
                                from_value,
                                to_value,
                                step: 0.0,
                            })
                        }
                        (Kind::Integer, Some((lo, hi))) => integer_range.push(raw::IntegerRange {
                            from_value: lo as i64,
                            to_value: hi as i64,
                            step: 1,
                        }),
                        _ => {}
                    }
                    raw::ParameterDescriptor {
                        name: n.clone(),
                        r#type: p.kind.raw(),
                        description: p.description.clone(),
                        additional_constraints: p.constraints.clone(),
                        read_only: p.read_only,
                        dynamic_typing: false,
                        floating_point_range,
                        integer_range,
                    }
                }
                None => raw::ParameterDescriptor {
                    name: n.clone(),
                    r#type: raw::ParameterType::NOT_SET,
                    description: String::new(),
                    additional_constraints: String::new(),
                    read_only: false,
                    dynamic_typing: false,
                    floating_point_range: Vec::new(),
                    integer_range: Vec::new(),
                },
            })
            .collect()
    }

    fn result(&self, r: Result<(), String>) -> raw::SetParametersResult {
        match r {
            Ok(()) => raw::SetParametersResult {
                successful: true,
                reason: String::new(),
            },
            Err(reason) => {
                if log_enabled(Level::Info) {
                    eprintln!("{}: refused a parameter set: {reason}", self.inner.tag);
                }
                raw::SetParametersResult {
                    successful: false,
                    reason,
                }
            }
        }
    }

    /// Serves the six services until the process ends.
    fn run(&self, s: Servers) {
        let ex = smol::LocalExecutor::new();
        let me = self;
        ex.spawn(answer(&s.get, |r| rcl::GetParametersResponse {
            values: me.values(&r.names),
        }))
        .detach();
        ex.spawn(answer(&s.types, |r| rcl::GetParameterTypesResponse {
            values: me.types(&r.names),
        }))
        .detach();
        ex.spawn(answer(&s.set, |r| rcl::SetParametersResponse {
            results: r
                .parameter
                .into_iter()
                .map(|p| me.result(me.set_many(&[(p.name, p.value.into())], true, true)))
                .collect(),
        }))
        .detach();
        ex.spawn(answer(&s.atomic, |r| {
            let sets: Vec<(String, ParameterValue)> = r
                .parameter
                .into_iter()
                .map(|p| (p.name, p.value.into()))
                .collect();
            rcl::SetParametersAtomicallyResponse {
                result: me.result(me.set_many(&sets, true, true)),
            }
        }))
        .detach();
        ex.spawn(answer(&s.list, |r| rcl::ListParametersResponse {
            result: me.list(&r.prefixes, r.depth),
        }))
        .detach();
        ex.spawn(answer(&s.describe, |r| rcl::DescribeParametersResponse {
            values: me.describe(&r.names),
        }))
        .detach();
        smol::block_on(ex.run(smol::future::pending::<()>()));
    }
}

/// Answers each request of `server` with `reply`, forever.
async fn answer<Req, Resp>(server: &ros2_client::Server<Req, Resp>, reply: impl Fn(Req) -> Resp)
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    use smol::stream::StreamExt;
    let mut requests = server.receive_request_stream();
    while let Some(r) = requests.next().await {
        match r {
            Ok((id, req)) => {
                let _ = server.async_send_response(id, reply(req)).await;
            }
            // (a request that does not decode: the next one)
            Err(_) => {
                smol::Timer::after(std::time::Duration::from_millis(20)).await;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParameterValue as V;

    #[test]
    fn values_are_taken_as_the_parameters_type_within_its_range() {
        let rate = Param::fixed("rate", Kind::Double, "Hz").range(10.0, 20000.0);
        assert_eq!(rate.coerce(&V::Integer(500)).unwrap(), V::Double(500.0));
        assert_eq!(rate.coerce(&V::Double(500.5)).unwrap(), V::Double(500.5));
        let e = rate.coerce(&V::Integer(5)).unwrap_err();
        assert_eq!(e, "parameter 'rate': 5.0 is out of its range 10 to 20000");
        let e = rate.coerce(&V::String("fast".into())).unwrap_err();
        assert_eq!(e, "parameter 'rate' is a double, not a string ('fast')");
        assert!(rate.coerce(&V::Double(f64::NAN)).is_err());
        let prio = Param::fixed("rt_priority", Kind::Integer, "").range(0.0, 99.0);
        assert_eq!(prio.coerce(&V::Double(70.0)).unwrap(), V::Integer(70));
        assert!(prio.coerce(&V::Double(70.5)).is_err());
        assert!(prio.coerce(&V::Integer(100)).is_err());
        let all = Param::live("record_all", Kind::Bool, "");
        assert_eq!(
            all.coerce(&V::String("yes".into())).unwrap(),
            V::Boolean(true)
        );
        assert_eq!(all.coerce(&V::Boolean(false)).unwrap(), V::Boolean(false));
        assert!(all.coerce(&V::Integer(1)).is_err());
        let dir = Param::live("record_dir", Kind::String, "");
        assert!(dir.coerce(&V::Integer(1)).is_err());
        let cpus = Param::fixed("cpu_affinity", Kind::IntegerArray, "").range(0.0, 1023.0);
        let a = |v: &[i64]| V::IntegerArray(v.to_vec());
        assert_eq!(cpus.coerce(&a(&[0, 1])).unwrap(), a(&[0, 1]));
        assert_eq!(cpus.coerce(&V::Integer(1)).unwrap(), a(&[1]));
        assert_eq!(cpus.coerce(&V::StringArray(vec![])).unwrap(), a(&[]));
        assert_eq!(cpus.coerce(&V::String("0, 1".into())).unwrap(), a(&[0, 1]));
        assert_eq!(cpus.coerce(&V::String(String::new())).unwrap(), a(&[]));
        assert_eq!(
            cpus.coerce(&V::String("one".into())).unwrap_err(),
            "parameter 'cpu_affinity' is an integer array, not a string ('one')"
        );
        assert_eq!(
            cpus.coerce(&a(&[1, 2000])).unwrap_err(),
            "parameter 'cpu_affinity': 2000 is out of its range 0 to 1023"
        );
        assert!(cpus.coerce(&V::Double(1.0)).is_err());
    }
}
