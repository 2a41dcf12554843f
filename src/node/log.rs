//! The node's log: every line goes to stdout (info and below) or stderr (warn
//! and above) as `NAME: message`, and to `/rosout` (rcl_interfaces/msg/Log)
//! once the node exists, with the node's logger name and the line's level.
//! `--ros-args --log-level LEVEL` drops lines below LEVEL from both.

use super::rosargs::LogLevel;
use ros2_client::rosout::{NodeLoggingHandle, RosoutRaw};
use std::sync::Mutex;

struct Sink {
    name: String,
    min: LogLevel,
    rosout: Option<NodeLoggingHandle>,
}

static SINK: Mutex<Option<Sink>> = Mutex::new(None);

/// Names the log (before the node exists: no /rosout yet).
pub fn init(name: &str, min: LogLevel) {
    if let Ok(mut s) = SINK.lock() {
        *s = Some(Sink {
            name: name.to_string(),
            min,
            rosout: None,
        });
    }
}

/// From now on, lines also go to /rosout through this node's writer.
pub fn attach(handle: NodeLoggingHandle) {
    if let Ok(mut s) = SINK.lock() {
        if let Some(s) = s.as_mut() {
            s.rosout = Some(handle);
        }
    }
}

/// Stops writing to /rosout (before the node is dropped).
pub fn detach() {
    if let Ok(mut s) = SINK.lock() {
        if let Some(s) = s.as_mut() {
            s.rosout = None;
        }
    }
}

/// The logger name rclcpp gives a node: its namespace and name joined by dots,
/// without the leading one (`/robot/t2` -> `robot.t2`).
pub fn logger_name(fqn: &str) -> String {
    fqn.trim_start_matches('/').replace('/', ".")
}

/// Writes one log line (see the module doc). Never fails.
pub fn emit(level: LogLevel, msg: &str, file: &str, line: u32) {
    use std::io::Write as _;
    let guard = SINK.lock();
    let sink = guard.as_ref().ok().and_then(|g| g.as_ref());
    let (name, min) = sink
        .map(|s| (s.name.as_str(), s.min))
        .unwrap_or(("truss_deploy", LogLevel::Info));
    if level < min {
        return;
    }
    if level >= LogLevel::Warn {
        let _ = writeln!(std::io::stderr(), "{name}: {msg}");
    } else {
        let _ = writeln!(std::io::stdout(), "{name}: {msg}");
    }
    if let Some(h) = sink.and_then(|s| s.rosout.as_ref()) {
        let stamp = ros2_client::builtin_interfaces::Time::now();
        h.rosout_raw(stamp, rosout_level(level), name, msg, file, "", line);
    }
}

fn rosout_level(l: LogLevel) -> ros2_client::log::LogLevel {
    match l {
        LogLevel::Debug => ros2_client::log::LogLevel::Debug,
        LogLevel::Info => ros2_client::log::LogLevel::Info,
        LogLevel::Warn => ros2_client::log::LogLevel::Warn,
        LogLevel::Error => ros2_client::log::LogLevel::Error,
        LogLevel::Fatal => ros2_client::log::LogLevel::Fatal,
    }
}

/// Logs at a level: `node_log!(Info, "x {}", 1)`.
macro_rules! node_log {
    ($lvl:ident, $($t:tt)*) => {
        $crate::node::log::emit(
            $crate::node::rosargs::LogLevel::$lvl,
            &format!($($t)*),
            file!(),
            line!(),
        )
    };
}
pub(crate) use node_log;

#[cfg(test)]
mod tests {
    #[test]
    fn logger_names_as_rclcpp() {
        assert_eq!(super::logger_name("/t2"), "t2");
        assert_eq!(super::logger_name("/robot/t2"), "robot.t2");
    }
}
