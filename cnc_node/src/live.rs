//! `cnc bag record` (live topics to MCAP, as `ros2 bag record` does) and
//! `cnc bag replay` (a recording republished on DDS at its own pace).

use crate::bag::Bag;
use crate::record::{
    from_cdr, stamp_ns, RecordSummary, Recorder, RecordingInfo, LIVE_CHUNK_SPAN_NS,
};
use cnc_msgs::ros;
use cnc_msgs::schema::RosSchema;
use cnc_msgs::*;
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Stops a live loop on Ctrl-C (SIGINT) or SIGTERM.
fn stop_flag() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    // a second handler cannot be set: then the caller's duration stops it
    let _ = ctrlc::set_handler(move || s.store(true, Ordering::SeqCst));
    stop
}

/// What to record.
pub struct LiveOpts {
    pub namespace: String,
    pub sim_namespace: String,
    pub domain: u16,
    /// stop after this long (else on Ctrl-C)
    pub duration: Option<Duration>,
}

/// Records the contract's topics until Ctrl-C or the duration.
pub fn record_live(opts: &LiveOpts, out: &Path) -> Result<RecordSummary, String> {
    let (_ctx, mut node) = ros::join(
        opts.domain,
        "/",
        &format!("cnc_bag_record_{}", std::process::id()),
    )?;
    let (cns, sns) = (opts.namespace.as_str(), opts.sim_namespace.as_str());
    let sp = ros::subscription::<JointState>(&mut node, cns, "joint_setpoints")?;
    let spin = ros::subscription::<Float64>(&mut node, cns, "spindle_command")?;
    let st = ros::subscription::<ControllerStatus>(&mut node, cns, "status")?;
    let js = ros::subscription::<JointState>(&mut node, sns, "joint_states")?;
    let enc = ros::subscription::<SpindleEncoder>(&mut node, sns, "spindle_encoder")?;
    let topic = |ns: &str, base: &str| format!("{}/{base}", ns.trim_end_matches('/'));
    let mut rec = Recorder::create(out, RecordingInfo::default())?;
    // a chunk per second of messages at most, also while the topics are
    // quiet: a killed recorder loses about a second
    rec.set_max_chunk_span(Some(LIVE_CHUNK_SPAN_NS));
    let c_sp = rec.channel::<JointState>(&topic(cns, "joint_setpoints"))?;
    let c_spin = rec.channel::<Float64>(&topic(cns, "spindle_command"))?;
    let c_st = rec.channel::<ControllerStatus>(&topic(cns, "status"))?;
    let c_js = rec.channel::<JointState>(&topic(sns, "joint_states"))?;
    let c_enc = rec.channel::<SpindleEncoder>(&topic(sns, "spindle_encoder"))?;
    let stop = stop_flag();
    let start = Instant::now();
    while !stop.load(Ordering::SeqCst) && opts.duration.is_none_or(|d| start.elapsed() < d) {
        let mut any = false;
        while let Ok(Some((m, _))) = sp.take() {
            rec.write(c_sp, stamp_ns(&m.header.stamp), &m)?;
            any = true;
        }
        while let Ok(Some((m, _))) = spin.take() {
            // Float64 has no stamp: the time it was received
            rec.write(c_spin, stamp_ns(&ros::wall_stamp()), &m)?;
            any = true;
        }
        while let Ok(Some((m, _))) = st.take() {
            rec.write(c_st, stamp_ns(&m.header.stamp), &m)?;
            any = true;
        }
        while let Ok(Some((m, _))) = js.take() {
            rec.write(c_js, stamp_ns(&m.header.stamp), &m)?;
            any = true;
        }
        while let Ok(Some((m, _))) = enc.take() {
            rec.write(c_enc, stamp_ns(&m.stamp), &m)?;
            any = true;
        }
        if !any {
            rec.close_stale_chunk(stamp_ns(&ros::wall_stamp()))?;
            std::thread::sleep(Duration::from_micros(500));
        }
    }
    rec.finish()
}

type Publish = Box<dyn FnMut(&[u8]) -> Result<(), String>>;

/// A function that decodes a payload of `T` and publishes it on `topic`.
fn publisher<T>(node: &mut ros2_client::Node, topic: &str) -> Result<Publish, String>
where
    T: RosSchema + Serialize + DeserializeOwned + std::fmt::Debug + 'static,
{
    let (ns, base) = match topic.rsplit_once('/') {
        Some(("", b)) => ("/", b),
        Some((n, b)) => (n, b),
        None => ("/", topic),
    };
    let p = ros::publisher::<T>(node, ns, base)?;
    let topic = topic.to_string();
    Ok(Box::new(move |data: &[u8]| {
        let m: T = from_cdr(data).map_err(|e| format!("{topic}: {e}"))?;
        p.publish(m).map_err(|e| format!("{topic}: {e:?}"))
    }))
}

/// The playback speed factors [`replay`] accepts (lowest, highest): a
/// recording's times divided by the rate stay within what a `Duration`
/// holds.
pub const REPLAY_RATES: (f64, f64) = (0.001, 1000.0);

/// Republishes every message of a recording on its topic, paced by the log
/// times (`rate` 2.0 plays twice as fast; see [`REPLAY_RATES`]). Returns
/// the messages published.
pub fn replay(path: &Path, rate: f64, domain: u16) -> Result<u64, String> {
    let (lo, hi) = REPLAY_RATES;
    if !(lo..=hi).contains(&rate) {
        return Err(format!(
            "--rate {rate}: must be a speed factor from {lo} to {hi}"
        ));
    }
    let bag = Bag::read(path)?;
    let (_ctx, mut node) = ros::join(
        domain,
        "/",
        &format!("cnc_bag_replay_{}", std::process::id()),
    )?;
    let mut pubs: Vec<Option<Publish>> = Vec::new();
    for (topic, data) in &bag.topics {
        let p = match data.type_name.as_str() {
            "sensor_msgs/msg/JointState" => Some(publisher::<JointState>(&mut node, topic)?),
            "std_msgs/msg/Float64" => Some(publisher::<Float64>(&mut node, topic)?),
            "std_msgs/msg/String" => Some(publisher::<StringMsg>(&mut node, topic)?),
            "cnc_msgs/msg/ControllerStatus" => {
                Some(publisher::<ControllerStatus>(&mut node, topic)?)
            }
            "cnc_msgs/msg/SpindleEncoder" => Some(publisher::<SpindleEncoder>(&mut node, topic)?),
            "tf2_msgs/msg/TFMessage" => Some(publisher::<TFMessage>(&mut node, topic)?),
            "geometry_msgs/msg/PoseStamped" => Some(publisher::<PoseStamped>(&mut node, topic)?),
            "sensor_msgs/msg/PointCloud2" => Some(publisher::<PointCloud2>(&mut node, topic)?),
            other => {
                eprintln!("replay: {topic}: type {other:?} is not replayed");
                None
            }
        };
        pubs.push(p);
    }
    // all messages in log-time order (stable: file order within a time)
    let mut order: Vec<(u64, usize, usize)> = Vec::new();
    for (ti, (_, data)) in bag.topics.iter().enumerate() {
        if pubs[ti].is_some() {
            order.extend(
                data.messages
                    .iter()
                    .enumerate()
                    .map(|(mi, (t, _))| (*t, ti, mi)),
            );
        }
    }
    order.sort_by_key(|&(t, ti, mi)| (t, ti, mi));
    // give subscribers a moment to match before the first message
    std::thread::sleep(Duration::from_millis(1500));
    let stop = stop_flag();
    let t0 = order.first().map_or(0, |o| o.0);
    let start = Instant::now();
    let mut n = 0u64;
    for (t, ti, mi) in order {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        // (at most 2^64 ns / 0.001: well within a Duration)
        let due =
            Duration::try_from_secs_f64((t - t0) as f64 * 1e-9 / rate).unwrap_or(Duration::MAX);
        if let Some(wait) = due.checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        if let Some(p) = pubs[ti].as_mut() {
            // a full reliable queue is a slow subscriber's problem, not ours
            if p(&bag.topics[ti].1.messages[mi].1).is_ok() {
                n += 1;
            }
        }
    }
    Ok(n)
}
