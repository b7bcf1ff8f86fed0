//! The machine as a robot model: a URDF made from its machine file
//! ([`Model::of`], [`Model::to_urdf`]; `cnc urdf`, and the node publishes
//! it on `<ns>/robot_description`), and the model's frames at a position
//! ([`Model::moving`], [`Model::fixed`]) for the node's `/tf` and
//! `/tf_static`, as `robot_state_publisher` would publish them.
//!
//! The model (frames in m, REP 103):
//!
//! - `world` → `base_link` (fixed): the machine's frame, the frame the
//!   joints' positions are in (`world` is the frame of recordings too);
//! - one prismatic joint per axis of the machine file, named as the axis
//!   (`x`, `y`, `z`: the names on `/cnc/joint_setpoints` and
//!   `/sim/joint_states`), along its coordinate, with the file's travel
//!   (`min_mm`, `max_mm`) as `lower`/`upper` and `max_velocity_mm_s` as
//!   `velocity`, in m; the machine file has no force limits, so `effort`
//!   (which URDF requires) is 0. Each moves a link `<axis>_slide`: a
//!   mill's X bridge, Y carriage and Z quill (in that order), a lathe's Z
//!   carriage and X cross slide;
//! - `tool` (fixed to the last slide): the tool tip, the point the
//!   setpoints command, so `world` → `tool` is the commanded X, Y, Z;
//! - with a `[spindle]`, a continuous joint `spindle` (about Z, velocity
//!   limit `max_rpm` in rad/s) turning `spindle_link`: on a mill above the
//!   tool, on a lathe the chuck on the bed.
//!
//! Geometry is for display only (boxes and cylinders sized from the
//! travel); there are no collision elements or inertias.

use crate::convert::{TOOL_FRAME, WORLD_FRAME};
use cnc_core::machine::MachineKind;
use cnc_core::Machine;
use std::fmt::Write;

/// The machine's root link (below `world`).
pub const BASE_LINK: &str = "base_link";
/// The spindle's joint and link.
pub const SPINDLE_JOINT: &str = "spindle";
pub const SPINDLE_LINK: &str = "spindle_link";

/// How a joint moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointKind {
    Fixed,
    /// along its axis, by a joint position (m)
    Prismatic,
    /// about its axis, by the spindle's angle (rad)
    Continuous,
}

/// A joint's `<limit>`: m, m/s (prismatic), rad/s (continuous).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
    pub effort: f64,
}

/// A joint of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub parent: String,
    pub child: String,
    /// where the child frame is in the parent's at position 0, m
    pub origin: [f64; 3],
    /// unit vector of the motion
    pub axis: [f64; 3],
    pub limit: Option<Limit>,
    /// the machine's joint (index into the setpoints) that moves it
    pub joint_index: Option<usize>,
}

/// A shape of a link's visual, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    Box([f64; 3]),
    /// radius, length (along the link's Z)
    Cylinder(f64, f64),
}

/// One visual of a link: a shape at an offset, in a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Visual {
    pub shape: Shape,
    pub at: [f64; 3],
    pub material: &'static str,
}

/// A link with its visuals.
#[derive(Clone, Debug, PartialEq)]
pub struct Link {
    pub name: String,
    pub visuals: Vec<Visual>,
}

/// The materials the visuals use: (name, rgba).
const MATERIALS: &[(&str, [f64; 4])] = &[
    ("frame", [0.55, 0.57, 0.6, 1.0]),
    ("slide", [0.3, 0.45, 0.7, 1.0]),
    ("spindle", [0.25, 0.25, 0.28, 1.0]),
    ("mark", [0.9, 0.3, 0.2, 1.0]),
    ("tool", [1.0, 0.85, 0.3, 1.0]),
];

/// The robot model of a machine.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    pub name: String,
    pub links: Vec<Link>,
    /// parents before children
    pub joints: Vec<Joint>,
}

/// The name of the link an axis moves.
pub fn slide_link(axis: &str) -> String {
    format!("{axis}_slide")
}

fn unit(c: usize) -> [f64; 3] {
    let mut a = [0.0; 3];
    a[c.min(2)] = 1.0;
    a
}

impl Model {
    /// The model of `machine` (see the module's text).
    pub fn of(machine: &Machine) -> Model {
        let coords = machine.joint_indices();
        // the travel of each coordinate, m (0..0 where no axis moves it)
        let mut lo = [0.0f64; 3];
        let mut hi = [0.0f64; 3];
        for (a, &c) in machine.axes.iter().zip(&coords) {
            lo[c] = a.min_mm / 1000.0;
            hi[c] = a.max_mm / 1000.0;
        }
        let mid = |c: usize| (lo[c] + hi[c]) / 2.0;
        let span = |c: usize| hi[c] - lo[c];
        let lathe = machine.kind == MachineKind::Lathe;
        // the order of the slides: a mill's X bridge carries the Y carriage,
        // which carries the Z quill; a lathe's Z carriage the X cross slide
        let mut order: Vec<usize> = (0..machine.axes.len().min(coords.len())).collect();
        order.sort_by_key(|&j| match (lathe, coords[j]) {
            (true, 2) => 0,
            (true, c) => c + 1,
            (false, c) => c,
        });
        let top = hi[2] + 0.15;
        let mut links = vec![
            Link {
                name: WORLD_FRAME.to_string(),
                visuals: Vec::new(),
            },
            Link {
                name: BASE_LINK.to_string(),
                visuals: vec![if lathe {
                    // the bed under the travel
                    Visual {
                        shape: Shape::Box([span(0) + 0.1, 0.04, span(2) + 0.2]),
                        at: [mid(0), -0.08, mid(2)],
                        material: "frame",
                    }
                } else {
                    // the table, its top at the lowest tool tip
                    Visual {
                        shape: Shape::Box([span(0) + 0.1, span(1) + 0.1, 0.02]),
                        at: [mid(0), mid(1), lo[2] - 0.01],
                        material: "frame",
                    }
                }],
            },
        ];
        let mut joints = vec![Joint {
            name: "base_joint".to_string(),
            kind: JointKind::Fixed,
            parent: WORLD_FRAME.to_string(),
            child: BASE_LINK.to_string(),
            origin: [0.0; 3],
            axis: [1.0, 0.0, 0.0],
            limit: None,
            joint_index: None,
        }];
        let mut parent = BASE_LINK.to_string();
        for &j in &order {
            let a = &machine.axes[j];
            let c = coords[j];
            let child = slide_link(&a.name);
            let shape = match (lathe, c) {
                // the Z carriage beside the work, the cross slide towards it
                (true, 2) => Visual {
                    shape: Shape::Box([0.06, 0.04, 0.12]),
                    at: [hi[0] + 0.08, -0.04, 0.0],
                    material: "slide",
                },
                (true, _) => Visual {
                    shape: Shape::Box([0.08, 0.03, 0.03]),
                    at: [0.05, 0.0, 0.0],
                    material: "slide",
                },
                // the X bridge across Y, the Y carriage on it, the Z quill
                (false, 0) => Visual {
                    shape: Shape::Box([0.04, span(1) + 0.1, 0.04]),
                    at: [0.0, mid(1), top],
                    material: "slide",
                },
                (false, 1) => Visual {
                    shape: Shape::Box([0.08, 0.08, 0.08]),
                    at: [0.0, 0.0, top],
                    material: "slide",
                },
                (false, _) => Visual {
                    shape: Shape::Cylinder(0.03, span(2) + 0.1),
                    at: [0.0, 0.0, 0.1 + (span(2) + 0.1) / 2.0],
                    material: "slide",
                },
            };
            links.push(Link {
                name: child.clone(),
                visuals: vec![shape],
            });
            joints.push(Joint {
                name: a.name.clone(),
                kind: JointKind::Prismatic,
                parent: parent.clone(),
                child: child.clone(),
                origin: [0.0; 3],
                axis: unit(c),
                limit: Some(Limit {
                    lower: a.min_mm / 1000.0,
                    upper: a.max_mm / 1000.0,
                    velocity: a.max_velocity_mm_s / 1000.0,
                    effort: 0.0,
                }),
                joint_index: Some(j),
            });
            parent = child;
        }
        // the tool tip, fixed to the last slide
        let radius = machine
            .tools
            .first()
            .map_or(0.003, |t| t.radius_mm / 1000.0)
            .max(0.0005);
        links.push(Link {
            name: TOOL_FRAME.to_string(),
            visuals: vec![if lathe {
                Visual {
                    shape: Shape::Box([0.012, 0.012, 0.012]),
                    at: [0.006, 0.0, 0.0],
                    material: "tool",
                }
            } else {
                Visual {
                    shape: Shape::Cylinder(radius, 0.04),
                    at: [0.0, 0.0, 0.02],
                    material: "tool",
                }
            }],
        });
        joints.push(Joint {
            name: "tool_joint".to_string(),
            kind: JointKind::Fixed,
            parent: parent.clone(),
            child: TOOL_FRAME.to_string(),
            origin: [0.0; 3],
            axis: [1.0, 0.0, 0.0],
            limit: None,
            joint_index: None,
        });
        if let Some(s) = &machine.spindle {
            // a chuck (lathe) or a collet above the tool (mill), with a
            // mark on its rim that shows it turn
            let (on, origin, r, len) = if lathe {
                (BASE_LINK.to_string(), [0.0, 0.0, lo[2] - 0.01], 0.06, 0.06)
            } else {
                (parent, [0.0, 0.0, 0.04], 0.02, 0.05)
            };
            let z = if lathe { -len / 2.0 } else { len / 2.0 };
            links.push(Link {
                name: SPINDLE_LINK.to_string(),
                visuals: vec![
                    Visual {
                        shape: Shape::Cylinder(r, len),
                        at: [0.0, 0.0, z],
                        material: "spindle",
                    },
                    Visual {
                        shape: Shape::Box([r * 0.5, r * 0.3, len * 1.02]),
                        at: [r * 0.8, 0.0, z],
                        material: "mark",
                    },
                ],
            });
            joints.push(Joint {
                name: SPINDLE_JOINT.to_string(),
                kind: JointKind::Continuous,
                parent: on,
                child: SPINDLE_LINK.to_string(),
                origin,
                axis: [0.0, 0.0, 1.0],
                limit: Some(Limit {
                    lower: 0.0,
                    upper: 0.0,
                    velocity: crate::convert::rpm_to_rad_s(s.max_rpm),
                    effort: 0.0,
                }),
                joint_index: None,
            });
        }
        Model {
            name: machine.name.clone(),
            links,
            joints,
        }
    }

    /// The URDF text (XML).
    pub fn to_urdf(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "<?xml version=\"1.0\"?>");
        let _ = writeln!(
            s,
            "<!-- made by cnc_node from the machine file (cnc urdf): joints named as on \
             /cnc/joint_setpoints, limits from the axes' travel and speed (m, m/s); effort 0: \
             the machine file gives no force limits -->"
        );
        let _ = writeln!(s, "<robot name=\"{}\">", xml(&self.name));
        for (name, [r, g, b, a]) in MATERIALS {
            let _ = writeln!(
                s,
                "  <material name=\"{name}\"><color rgba=\"{r} {g} {b} {a}\"/></material>"
            );
        }
        for l in &self.links {
            if l.visuals.is_empty() {
                let _ = writeln!(s, "  <link name=\"{}\"/>", xml(&l.name));
                continue;
            }
            let _ = writeln!(s, "  <link name=\"{}\">", xml(&l.name));
            for v in &l.visuals {
                let geometry = match v.shape {
                    Shape::Box(size) => format!("<box size=\"{}\"/>", v3(um(size))),
                    Shape::Cylinder(r, len) => format!(
                        "<cylinder radius=\"{}\" length=\"{}\"/>",
                        n(um([r, 0.0, 0.0])[0]),
                        n(um([len, 0.0, 0.0])[0])
                    ),
                };
                let _ = writeln!(
                    s,
                    "    <visual><origin xyz=\"{}\"/><geometry>{geometry}</geometry>\
                     <material name=\"{}\"/></visual>",
                    v3(um(v.at)),
                    v.material
                );
            }
            let _ = writeln!(s, "  </link>");
        }
        for j in &self.joints {
            let kind = match j.kind {
                JointKind::Fixed => "fixed",
                JointKind::Prismatic => "prismatic",
                JointKind::Continuous => "continuous",
            };
            let _ = writeln!(s, "  <joint name=\"{}\" type=\"{kind}\">", xml(&j.name));
            let _ = writeln!(s, "    <parent link=\"{}\"/>", xml(&j.parent));
            let _ = writeln!(s, "    <child link=\"{}\"/>", xml(&j.child));
            let _ = writeln!(s, "    <origin xyz=\"{}\" rpy=\"0 0 0\"/>", v3(j.origin));
            if j.kind != JointKind::Fixed {
                let _ = writeln!(s, "    <axis xyz=\"{}\"/>", v3(j.axis));
            }
            match (j.kind, j.limit) {
                (JointKind::Prismatic, Some(l)) => {
                    let _ = writeln!(
                        s,
                        "    <limit lower=\"{}\" upper=\"{}\" velocity=\"{}\" effort=\"{}\"/>",
                        n(l.lower),
                        n(l.upper),
                        n(l.velocity),
                        n(l.effort)
                    );
                }
                (JointKind::Continuous, Some(l)) => {
                    let _ = writeln!(
                        s,
                        "    <limit velocity=\"{}\" effort=\"{}\"/>",
                        n(l.velocity),
                        n(l.effort)
                    );
                }
                _ => {}
            }
            let _ = writeln!(s, "  </joint>");
        }
        s.push_str("</robot>\n");
        s
    }

    /// The frames of the moving joints with the machine's joints at
    /// `positions` (m, in the machine's joint order) and the spindle at
    /// `spindle_rad`: (parent, child, translation m, rotation quaternion
    /// x, y, z, w).
    pub fn moving(&self, positions: &[f64], spindle_rad: f64) -> Vec<Frame> {
        self.joints
            .iter()
            .filter_map(|j| match j.kind {
                JointKind::Fixed => None,
                JointKind::Prismatic => {
                    let p = j
                        .joint_index
                        .and_then(|i| positions.get(i))
                        .copied()
                        .filter(|p| p.is_finite())
                        .unwrap_or(0.0);
                    Some(Frame {
                        parent: j.parent.clone(),
                        child: j.child.clone(),
                        translation: std::array::from_fn(|k| j.origin[k] + j.axis[k] * p),
                        rotation: [0.0, 0.0, 0.0, 1.0],
                    })
                }
                JointKind::Continuous => {
                    let h = if spindle_rad.is_finite() {
                        spindle_rad.rem_euclid(std::f64::consts::TAU) / 2.0
                    } else {
                        0.0
                    };
                    let (s, c) = h.sin_cos();
                    Some(Frame {
                        parent: j.parent.clone(),
                        child: j.child.clone(),
                        translation: j.origin,
                        rotation: [j.axis[0] * s, j.axis[1] * s, j.axis[2] * s, c],
                    })
                }
            })
            .collect()
    }

    /// The frames of the fixed joints (for `/tf_static`).
    pub fn fixed(&self) -> Vec<Frame> {
        self.joints
            .iter()
            .filter(|j| j.kind == JointKind::Fixed)
            .map(|j| Frame {
                parent: j.parent.clone(),
                child: j.child.clone(),
                translation: j.origin,
                rotation: [0.0, 0.0, 0.0, 1.0],
            })
            .collect()
    }
}

/// A transform between two frames of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub parent: String,
    pub child: String,
    /// m
    pub translation: [f64; 3],
    /// quaternion x, y, z, w
    pub rotation: [f64; 4],
}

/// The URDF of a machine.
pub fn urdf(machine: &Machine) -> String {
    Model::of(machine).to_urdf()
}

/// `cnc urdf`: prints the URDF of a machine file or bundled machine.
pub fn print(machine: &str) -> Result<(), String> {
    print!("{}", urdf(&crate::files::load_machine(machine)?));
    Ok(())
}

/// A number in the URDF: the shortest text that reads back as the same
/// f64 (-0 as 0).
fn n(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v}")
    }
}

/// A display dimension rounded to the µm (the limits are not rounded).
fn um(v: [f64; 3]) -> [f64; 3] {
    v.map(|x| (x * 1e6).round() / 1e6)
}

fn v3([x, y, z]: [f64; 3]) -> String {
    format!("{} {} {}", n(x), n(y), n(z))
}

/// Text for an XML attribute.
fn xml(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\t' => o.push(' '),
            c => o.push(c),
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (name, type, parent, child, limit attributes) of every joint, read
    /// back from the XML with a real parser.
    type JointRow = (String, String, String, String, Vec<(String, f64)>);

    fn parse(text: &str) -> (String, Vec<String>, Vec<JointRow>) {
        let doc = roxmltree::Document::parse(text).expect("well-formed XML");
        let robot = doc.root_element();
        assert_eq!(robot.tag_name().name(), "robot");
        let links = robot
            .children()
            .filter(|n| n.has_tag_name("link"))
            .map(|n| n.attribute("name").unwrap().to_string())
            .collect();
        let joints = robot
            .children()
            .filter(|n| n.has_tag_name("joint"))
            .map(|j| {
                let child = |tag: &str| {
                    j.children()
                        .find(|n| n.has_tag_name(tag))
                        .and_then(|n| n.attribute("link"))
                        .unwrap()
                        .to_string()
                };
                let limit = j
                    .children()
                    .find(|n| n.has_tag_name("limit"))
                    .map(|l| {
                        l.attributes()
                            .map(|a| (a.name().to_string(), a.value().parse::<f64>().unwrap()))
                            .collect()
                    })
                    .unwrap_or_default();
                (
                    j.attribute("name").unwrap().to_string(),
                    j.attribute("type").unwrap().to_string(),
                    child("parent"),
                    child("child"),
                    limit,
                )
            })
            .collect();
        (robot.attribute("name").unwrap().to_string(), links, joints)
    }

    fn limit(l: &[(String, f64)], k: &str) -> f64 {
        l.iter().find(|(n, _)| n == k).map(|(_, v)| *v).unwrap()
    }

    /// Every axis of the machine file is a prismatic joint of its name with
    /// its travel and speed in m; the tree is connected from `world`.
    fn check(m: &Machine) {
        let text = urdf(m);
        let (name, links, joints) = parse(&text);
        assert_eq!(name, m.name);
        for a in &m.axes {
            let (_, ty, _, child, l) = joints
                .iter()
                .find(|j| j.0 == a.name)
                .unwrap_or_else(|| panic!("no joint {}", a.name));
            assert_eq!(ty, "prismatic");
            assert_eq!(child, &slide_link(&a.name));
            assert_eq!(limit(l, "lower"), a.min_mm / 1000.0);
            assert_eq!(limit(l, "upper"), a.max_mm / 1000.0);
            assert_eq!(limit(l, "velocity"), a.max_velocity_mm_s / 1000.0);
            assert_eq!(limit(l, "effort"), 0.0);
        }
        let prismatic: Vec<&str> = joints
            .iter()
            .filter(|j| j.1 == "prismatic")
            .map(|j| j.0.as_str())
            .collect();
        assert_eq!(prismatic.len(), m.axes.len());
        // a tree: every link but world is the child of exactly one joint,
        // whose parent is a link
        for l in &links {
            let parents = joints.iter().filter(|j| &j.3 == l).count();
            assert_eq!(parents, usize::from(l != WORLD_FRAME), "{l}");
        }
        for j in &joints {
            assert!(links.contains(&j.2) && links.contains(&j.3), "{j:?}");
        }
        assert!(links.iter().any(|l| l == TOOL_FRAME));
        let spindle = joints.iter().find(|j| j.0 == SPINDLE_JOINT).unwrap();
        assert_eq!(spindle.1, "continuous");
        let max_rpm = m.spindle.as_ref().unwrap().max_rpm;
        assert!(
            (limit(&spindle.4, "velocity") - max_rpm * std::f64::consts::TAU / 60.0).abs() < 1e-9
        );
    }

    #[test]
    fn the_mill_and_the_lathe_have_their_machine_files_joints_and_limits() {
        let mill = Machine::builtin_mill();
        check(&mill);
        let lathe = Machine::builtin_lathe();
        check(&lathe);
        // the bundled files' numbers, in m: the mill's X 0..500 mm at
        // 250 mm/s, Z -100..100 at 150; the lathe's X (radius) -5..150
        let (_, _, j) = parse(&urdf(&mill));
        let x = j.iter().find(|j| j.0 == "x").unwrap();
        assert_eq!(
            (
                limit(&x.4, "lower"),
                limit(&x.4, "upper"),
                limit(&x.4, "velocity")
            ),
            (0.0, 0.5, 0.25)
        );
        let z = j.iter().find(|j| j.0 == "z").unwrap();
        assert_eq!((limit(&z.4, "lower"), limit(&z.4, "upper")), (-0.1, 0.1));
        assert_eq!(limit(&z.4, "velocity"), 0.15);
        let (_, _, j) = parse(&urdf(&lathe));
        let x = j.iter().find(|j| j.0 == "x").unwrap();
        assert_eq!((limit(&x.4, "lower"), limit(&x.4, "upper")), (-0.005, 0.15));
        assert!(j.iter().all(|j| j.0 != "y"));
    }

    #[test]
    fn a_machine_file_with_other_travel_gives_other_limits() {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/mill.toml"),
        )
        .unwrap()
        .replace("min_mm = -100.0", "min_mm = -42.5")
        .replace("name = \"mill\"", "name = \"a <small> & \\\"odd\\\" mill\"");
        let m = Machine::from_toml(&text).unwrap();
        check(&m);
        let (name, _, j) = parse(&urdf(&m));
        assert_eq!(name, "a <small> & \"odd\" mill");
        let z = j.iter().find(|j| j.0 == "z").unwrap();
        assert_eq!(limit(&z.4, "lower"), -0.0425);
    }

    #[test]
    fn the_frames_put_the_tool_at_the_joint_positions() {
        for m in [Machine::builtin_mill(), Machine::builtin_lathe()] {
            let model = Model::of(&m);
            let coords = m.joint_indices();
            let pos: Vec<f64> = (0..m.axes.len())
                .map(|j| 0.01 * (j as f64 + 1.0) - 0.025)
                .collect();
            // world -> tool: the sum of the chain's translations (no
            // rotations on the way to the tool)
            let mut frames = model.fixed();
            frames.extend(model.moving(&pos, 1.0));
            let mut at = TOOL_FRAME.to_string();
            let mut sum = [0.0; 3];
            while at != WORLD_FRAME {
                let f = frames.iter().find(|f| f.child == at).unwrap();
                assert_eq!(f.rotation, [0.0, 0.0, 0.0, 1.0]);
                for (s, t) in sum.iter_mut().zip(f.translation) {
                    *s += t;
                }
                at = f.parent.clone();
            }
            let mut want = [0.0; 3];
            for (j, &c) in coords.iter().enumerate() {
                want[c] = pos[j];
            }
            assert_eq!(sum, want, "{}", m.name);
            // the spindle turns about Z by the angle
            let s = frames.iter().find(|f| f.child == SPINDLE_LINK).unwrap();
            let [x, y, z, w] = s.rotation;
            assert_eq!((x, y), (0.0, 0.0));
            assert!((2.0 * z.atan2(w) - 1.0).abs() < 1e-12);
        }
    }
}
