//! Parameter values and parameters files as rcl reads them: YAML values
//! (`-p name:=VALUE`), and files of `node: ros__parameters: {...}`
//! sections (`--params-file`), with the node keys' wildcards.

use crate::ros_args::{absolute, check_param_name};
use ros2_client::ParameterValue;
use std::path::Path;
use yaml_rust2::{Yaml, YamlLoader};

/// A value as rcl reads one: YAML, a scalar or a list of one type.
pub fn yaml_value(text: &str) -> Result<ParameterValue, String> {
    if text.trim().is_empty() {
        return Ok(ParameterValue::String(String::new()));
    }
    let docs = YamlLoader::load_from_str(text).map_err(|e| format!("not YAML: {e}"))?;
    match docs.first() {
        None => Ok(ParameterValue::String(String::new())),
        Some(y) => from_yaml(y),
    }
}

fn from_yaml(y: &Yaml) -> Result<ParameterValue, String> {
    Ok(match y {
        Yaml::Integer(i) => ParameterValue::Integer(*i),
        Yaml::Real(_) => {
            ParameterValue::Double(y.as_f64().ok_or_else(|| format!("bad number {y:?}"))?)
        }
        Yaml::Boolean(b) => ParameterValue::Boolean(*b),
        Yaml::String(s) => ParameterValue::String(s.clone()),
        Yaml::Array(a) => array(a)?,
        Yaml::Null => return Err("no value (null)".into()),
        Yaml::Hash(_) => return Err("a mapping is not a parameter value".into()),
        Yaml::Alias(_) | Yaml::BadValue => return Err("not a parameter value".into()),
    })
}

fn array(a: &[Yaml]) -> Result<ParameterValue, String> {
    let all = |f: fn(&Yaml) -> bool| a.iter().all(f);
    Ok(if a.is_empty() {
        ParameterValue::StringArray(Vec::new())
    } else if all(|y| matches!(y, Yaml::Boolean(_))) {
        ParameterValue::BooleanArray(a.iter().filter_map(Yaml::as_bool).collect())
    } else if all(|y| matches!(y, Yaml::Integer(_))) {
        ParameterValue::IntegerArray(a.iter().filter_map(Yaml::as_i64).collect())
    } else if all(|y| matches!(y, Yaml::Integer(_) | Yaml::Real(_))) {
        let mut v = Vec::with_capacity(a.len());
        for y in a {
            match y {
                Yaml::Integer(i) => v.push(*i as f64),
                _ => v.push(y.as_f64().ok_or_else(|| format!("bad number {y:?}"))?),
            }
        }
        ParameterValue::DoubleArray(v)
    } else if all(|y| matches!(y, Yaml::String(_))) {
        ParameterValue::StringArray(
            a.iter()
                .filter_map(|y| y.as_str().map(str::to_string))
                .collect(),
        )
    } else {
        return Err("a list must hold values of one type".into());
    })
}

/// Largest parameters file read.
const MAX_PARAMS_FILE: u64 = 4 << 20;

/// Whether a parameters file's node key (`/**`, `/ns/node`, `/*/node`, ...)
/// names the node `fqn`: `*` is one token, `**` any number of them.
pub fn node_matches(key: &str, fqn: &str) -> bool {
    let k: Vec<&str> = key.split('/').filter(|t| !t.is_empty()).collect();
    let f: Vec<&str> = fqn.split('/').filter(|t| !t.is_empty()).collect();
    fn m(k: &[&str], f: &[&str]) -> bool {
        match k.split_first() {
            None => f.is_empty(),
            Some((&"**", rest)) => (0..=f.len()).any(|i| m(rest, &f[i..])),
            Some((t, rest)) => f
                .split_first()
                .is_some_and(|(g, fr)| (*t == "*" || t == g) && m(rest, fr)),
        }
    }
    m(&k, &f)
}

/// (node key, [(parameter, value)]) of each `ros__parameters` section of a
/// parameters file, in file order.
pub type Sections = Vec<(String, Vec<(String, ParameterValue)>)>;

/// Reads a parameters file in rcl's format.
pub fn read_params_file(path: &Path) -> Result<Sections, String> {
    let shown = path.display();
    let meta = std::fs::metadata(path).map_err(|e| format!("--params-file {shown}: {e}"))?;
    if meta.len() > MAX_PARAMS_FILE {
        return Err(format!(
            "--params-file {shown}: {} bytes, more than the {MAX_PARAMS_FILE} a parameters file may have",
            meta.len()
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("--params-file {shown}: {e}"))?;
    params_from_yaml(&text).map_err(|e| format!("--params-file {shown}: {e}"))
}

/// The sections of a parameters file's text.
pub fn params_from_yaml(text: &str) -> Result<Sections, String> {
    let docs = YamlLoader::load_from_str(text).map_err(|e| format!("not YAML: {e}"))?;
    let mut out = Vec::new();
    for d in &docs {
        match d {
            Yaml::Hash(_) => walk_nodes(d, &mut Vec::new(), &mut out)?,
            Yaml::Null => {}
            _ => return Err("expected a mapping of node names".into()),
        }
    }
    Ok(out)
}

fn key_str(k: &Yaml) -> Result<String, String> {
    match k {
        Yaml::String(s) => Ok(s.clone()),
        Yaml::Integer(i) => Ok(i.to_string()),
        Yaml::Boolean(b) => Ok(b.to_string()),
        _ => Err(format!("a key must be a name, not {k:?}")),
    }
}

const MAX_DEPTH: usize = 32;

fn walk_nodes(y: &Yaml, path: &mut Vec<String>, out: &mut Sections) -> Result<(), String> {
    if path.len() > MAX_DEPTH {
        return Err("node names nested too deep".into());
    }
    let Yaml::Hash(h) = y else {
        return Err(format!(
            "'{}': expected 'ros__parameters:' under a node name",
            path.join("/")
        ));
    };
    for (k, v) in h {
        let k = key_str(k)?;
        if k == "ros__parameters" {
            if path.is_empty() {
                return Err("'ros__parameters' needs a node name above it".into());
            }
            let key = absolute(&path.join("/"));
            let key = collapse_slashes(&key);
            let mut params = Vec::new();
            if !matches!(v, Yaml::Null) {
                walk_params(v, &mut String::new(), 0, &mut params)
                    .map_err(|e| format!("'{key}': {e}"))?;
            }
            out.push((key, params));
        } else {
            path.push(k);
            walk_nodes(v, path, out)?;
            path.pop();
        }
    }
    Ok(())
}

fn collapse_slashes(s: &str) -> String {
    let t: Vec<&str> = s.split('/').filter(|t| !t.is_empty()).collect();
    format!("/{}", t.join("/"))
}

fn walk_params(
    y: &Yaml,
    prefix: &mut String,
    depth: usize,
    out: &mut Vec<(String, ParameterValue)>,
) -> Result<(), String> {
    if depth > MAX_DEPTH {
        return Err("parameter names nested too deep".into());
    }
    let Yaml::Hash(h) = y else {
        return Err("expected a mapping of parameter names under 'ros__parameters'".into());
    };
    for (k, v) in h {
        let k = key_str(k)?;
        let len = prefix.len();
        if !prefix.is_empty() {
            prefix.push('.');
        }
        prefix.push_str(&k);
        match v {
            Yaml::Hash(_) => walk_params(v, prefix, depth + 1, out)?,
            _ => {
                check_param_name(prefix).map_err(|e| format!("parameter '{prefix}': {e}"))?;
                let value = from_yaml(v).map_err(|e| format!("parameter '{prefix}': {e}"))?;
                out.push((prefix.clone(), value));
            }
        }
        prefix.truncate(len);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_read_as_yaml() {
        use ParameterValue as V;
        assert_eq!(yaml_value("500").unwrap(), V::Integer(500));
        // launch_ros writes `name:=` + yaml.dump(value)
        assert_eq!(yaml_value("500\n...\n").unwrap(), V::Integer(500));
        assert_eq!(yaml_value("1.5").unwrap(), V::Double(1.5));
        assert_eq!(yaml_value("true").unwrap(), V::Boolean(true));
        assert_eq!(yaml_value("'true'").unwrap(), V::String("true".into()));
        assert_eq!(yaml_value("/tmp/x").unwrap(), V::String("/tmp/x".into()));
        assert_eq!(yaml_value("").unwrap(), V::String(String::new()));
        assert_eq!(
            yaml_value("[a, b]").unwrap(),
            V::StringArray(vec!["a".into(), "b".into()])
        );
    }

    #[test]
    fn node_keys_match_with_wildcards() {
        assert!(node_matches("/**", "/cnc/cnc_node"));
        assert!(node_matches("/**/cnc_node", "/cnc/cnc_node"));
        assert!(node_matches("/**/cnc_node", "/cnc_node"));
        assert!(node_matches("/*/cnc_node", "/cnc/cnc_node"));
        assert!(!node_matches("/*/cnc_node", "/a/b/cnc_node"));
        assert!(node_matches("/cnc/cnc_node", "/cnc/cnc_node"));
        assert!(!node_matches("/cnc_node", "/cnc/cnc_node"));
    }
}
