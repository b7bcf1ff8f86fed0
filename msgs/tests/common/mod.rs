//! The .msg parser the interface tests share.

use cnc_msgs::RosType;

pub type Pairs = Vec<(String, String)>;

/// (name, type) of the fields and (name, value) of the constants of a
/// .msg text (or one half of a .srv).
pub fn parse(text: &str) -> (Pairs, Pairs) {
    let mut fields = Vec::new();
    let mut consts = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line.split_once(char::is_whitespace).unwrap();
        let rest = rest.trim();
        if let Some((name, value)) = rest.split_once('=') {
            consts.push((name.trim().to_string(), value.trim().to_string()));
        } else {
            // "float64 w 1": a default value may follow the name
            let name = rest.split_whitespace().next().unwrap();
            fields.push((name.to_string(), ty.to_string()));
        }
    }
    (fields, consts)
}

/// The field list a Rust type declares.
pub fn fields_of<T: RosType>() -> Pairs {
    T::FIELDS
        .iter()
        .map(|(n, t)| (n.to_string(), t.to_string()))
        .collect()
}
