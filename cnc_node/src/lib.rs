//! Shell around the pure core: loading machine files and programs, the
//! offline simulation loop shared by `cnc simulate` and the tests, and (later)
//! the ROS 2 node.

pub mod action;
pub mod admit;
pub mod bag;
pub mod chunks;
pub mod client;
pub mod controller;
pub mod convert;
pub mod diagnostics;
pub mod files;
pub mod live;
pub mod observe;
pub mod offline;
pub mod params;
pub mod plot;
pub mod program;
pub mod record;
pub mod recover;
pub mod rt_queue;
pub mod urdf;
