//! rcl_interfaces' parameter services of the node (`<node>/list_parameters`,
//! `get_parameters`, `get_parameter_types`, `set_parameters`,
//! `set_parameters_atomically`, `describe_parameters`), as `ros2 param` calls
//! them, answering every client in its own service mapping like the node's
//! other services ([`super::services::Service`]). The values live in
//! [`Params`]; the handlers here are pure. A set that changes values is
//! announced on `/parameter_events` (rcl_interfaces/ParameterEvent).

use super::params::{Descriptor, Kind, Params};
use super::rosargs::ParamValue;
use super::services::Service;
use super::Naming;
use ros2_client::dds::rustdds::Topic;
use ros2_client::parameters::raw;
use ros2_client::rcl_interfaces::*;
use ros2_client::{Node, Publisher, ServiceMapping, ServiceTypeName};
use std::time::Instant;

/// raw::ParameterValue of a value.
pub fn to_raw(v: &ParamValue) -> raw::ParameterValue {
    let mut r = raw::ParameterValue {
        ptype: raw::ParameterType::NOT_SET,
        boolean_value: false,
        int_value: 0,
        double_value: 0.0,
        string_value: String::new(),
        byte_array: Vec::new(),
        bool_array: Vec::new(),
        int_array: Vec::new(),
        double_array: Vec::new(),
        string_array: Vec::new(),
    };
    match v {
        ParamValue::Bool(b) => (r.ptype, r.boolean_value) = (raw::ParameterType::BOOL, *b),
        ParamValue::Int(i) => (r.ptype, r.int_value) = (raw::ParameterType::INTEGER, *i),
        ParamValue::Double(d) => (r.ptype, r.double_value) = (raw::ParameterType::DOUBLE, *d),
        ParamValue::Str(s) => (r.ptype, r.string_value) = (raw::ParameterType::STRING, s.clone()),
        ParamValue::BoolArray(a) => {
            (r.ptype, r.bool_array) = (raw::ParameterType::BOOL_ARRAY, a.clone())
        }
        ParamValue::IntArray(a) => {
            (r.ptype, r.int_array) = (raw::ParameterType::INTEGER_ARRAY, a.clone())
        }
        ParamValue::DoubleArray(a) => {
            (r.ptype, r.double_array) = (raw::ParameterType::DOUBLE_ARRAY, a.clone())
        }
        ParamValue::StrArray(a) => {
            (r.ptype, r.string_array) = (raw::ParameterType::STRING_ARRAY, a.clone())
        }
    }
    r
}

/// The value a raw::ParameterValue carries, or why it cannot be one here.
pub fn from_raw(r: &raw::ParameterValue) -> Result<ParamValue, String> {
    use raw::ParameterType as T;
    Ok(match r.ptype {
        T::BOOL => ParamValue::Bool(r.boolean_value),
        T::INTEGER => ParamValue::Int(r.int_value),
        T::DOUBLE => ParamValue::Double(r.double_value),
        T::STRING => ParamValue::Str(r.string_value.clone()),
        T::BOOL_ARRAY => ParamValue::BoolArray(r.bool_array.clone()),
        T::INTEGER_ARRAY => ParamValue::IntArray(r.int_array.clone()),
        T::DOUBLE_ARRAY => ParamValue::DoubleArray(r.double_array.clone()),
        T::STRING_ARRAY => ParamValue::StrArray(r.string_array.clone()),
        T::NOT_SET => return Err("parameters of this node cannot be undeclared".into()),
        T::BYTE_ARRAY => return Err("no parameter of this node is a byte array".into()),
        t => return Err(format!("unknown parameter type {t}")),
    })
}

fn kind_code(k: Kind) -> u8 {
    match k {
        Kind::Bool => raw::ParameterType::BOOL,
        Kind::Double => raw::ParameterType::DOUBLE,
        Kind::Str => raw::ParameterType::STRING,
        Kind::StrArray => raw::ParameterType::STRING_ARRAY,
    }
}

fn describe(d: &Descriptor) -> raw::ParameterDescriptor {
    raw::ParameterDescriptor {
        name: d.name.to_string(),
        r#type: kind_code(d.kind),
        description: d.description.to_string(),
        additional_constraints: String::new(),
        read_only: d.read_only,
        dynamic_typing: false,
        floating_point_range: d
            .range
            .map(|(lo, hi)| raw::FloatingPointRange {
                from_value: lo,
                to_value: hi,
                step: 0.0,
            })
            .into_iter()
            .collect(),
        integer_range: Vec::new(),
    }
}

fn not_set() -> raw::ParameterValue {
    to_raw(&ParamValue::Bool(false)).with_type(raw::ParameterType::NOT_SET)
}

trait WithType {
    fn with_type(self, t: u8) -> Self;
}
impl WithType for raw::ParameterValue {
    fn with_type(mut self, t: u8) -> Self {
        self.ptype = t;
        self
    }
}

/// ListParameters: names under the prefixes (all with none); this node's
/// names have no dots, so depth does not cut any.
pub fn list(p: &Params, req: &ListParametersRequest) -> ListParametersResponse {
    let names = p
        .names()
        .into_iter()
        .filter(|n| {
            req.prefixes.is_empty()
                || req
                    .prefixes
                    .iter()
                    .any(|x| n == x || n.starts_with(&format!("{x}.")))
        })
        .map(str::to_string)
        .collect();
    ListParametersResponse {
        result: ListParametersResult {
            names,
            prefixes: Vec::new(),
        },
    }
}

pub fn get(p: &Params, req: &GetParametersRequest) -> GetParametersResponse {
    GetParametersResponse {
        values: req
            .names
            .iter()
            .map(|n| p.get(n).map(to_raw).unwrap_or_else(not_set))
            .collect(),
    }
}

pub fn get_types(p: &Params, req: &GetParameterTypesRequest) -> GetParameterTypesResponse {
    GetParameterTypesResponse {
        values: req
            .names
            .iter()
            .map(|n| {
                p.descriptor(n)
                    .map(|d| kind_code(d.kind))
                    .unwrap_or(raw::ParameterType::NOT_SET)
            })
            .collect(),
    }
}

pub fn describe_params(p: &Params, req: &DescribeParametersRequest) -> DescribeParametersResponse {
    DescribeParametersResponse {
        values: req
            .names
            .iter()
            .filter_map(|n| p.descriptor(n).map(describe))
            .collect(),
    }
}

fn result(r: Result<(), String>) -> raw::SetParametersResult {
    match r {
        Ok(()) => raw::SetParametersResult {
            successful: true,
            reason: String::new(),
        },
        Err(reason) => raw::SetParametersResult {
            successful: false,
            reason,
        },
    }
}

/// SetParameters: each one on its own (a refused one, with its reason, leaves
/// the others); `changed` gets the names set.
pub fn set(
    p: &mut Params,
    req: &SetParametersRequest,
    changed: &mut Vec<String>,
) -> SetParametersResponse {
    SetParametersResponse {
        results: req
            .parameter
            .iter()
            .map(|x| {
                let r = from_raw(&x.value).and_then(|v| p.set(&x.name, v));
                if r.is_ok() {
                    changed.push(x.name.clone());
                }
                result(r)
            })
            .collect(),
    }
}

/// SetParametersAtomically: all or none.
pub fn set_atomically(
    p: &mut Params,
    req: &SetParametersRequest,
    changed: &mut Vec<String>,
) -> SetParametersAtomicallyResponse {
    let mut trial = p.clone();
    let mut names = Vec::new();
    let mut r = Ok(());
    for x in &req.parameter {
        r = from_raw(&x.value)
            .and_then(|v| trial.set(&x.name, v))
            .map_err(|e| format!("{}: {e}", x.name));
        if r.is_err() {
            break;
        }
        names.push(x.name.clone());
    }
    if r.is_ok() {
        *p = trial;
        changed.extend(names);
    }
    SetParametersAtomicallyResponse { result: result(r) }
}

/// The six services.
pub struct ParamServices {
    list: Service<ListParametersRequest, ListParametersResponse>,
    get: Service<GetParametersRequest, GetParametersResponse>,
    get_types: Service<GetParameterTypesRequest, GetParameterTypesResponse>,
    set: Service<SetParametersRequest, SetParametersResponse>,
    set_atomically: Service<SetParametersRequest, SetParametersAtomicallyResponse>,
    describe: Service<DescribeParametersRequest, DescribeParametersResponse>,
    events: Publisher<raw::ParameterEvent>,
    node_fqn: String,
}

impl ParamServices {
    /// Creates them under the node's name (`~/get_parameters`, ...).
    /// `events_topic`: the context's `/parameter_events`.
    pub fn new(
        node: &mut Node,
        names: &Naming,
        forced: Option<ServiceMapping>,
        events_topic: &Topic,
    ) -> Result<Self, String> {
        fn mk<Q, R>(
            node: &mut Node,
            names: &Naming,
            forced: Option<ServiceMapping>,
            base: &str,
            ty: &str,
        ) -> Result<Service<Q, R>, String>
        where
            Q: ros2_client::Message + Clone + 'static,
            R: ros2_client::Message + 'static,
        {
            Service::new(
                node,
                &names.name(&format!("~/{base}"))?,
                &ServiceTypeName::new("rcl_interfaces", ty),
                forced,
            )
        }
        Ok(ParamServices {
            list: mk(node, names, forced, "list_parameters", "ListParameters")?,
            get: mk(node, names, forced, "get_parameters", "GetParameters")?,
            get_types: mk(
                node,
                names,
                forced,
                "get_parameter_types",
                "GetParameterTypes",
            )?,
            set: mk(node, names, forced, "set_parameters", "SetParameters")?,
            set_atomically: mk(
                node,
                names,
                forced,
                "set_parameters_atomically",
                "SetParametersAtomically",
            )?,
            describe: mk(
                node,
                names,
                forced,
                "describe_parameters",
                "DescribeParameters",
            )?,
            events: node
                .create_publisher(events_topic, None)
                .map_err(|e| format!("create /parameter_events writer: {e:?}"))?,
            node_fqn: names.full("~")?,
        })
    }

    /// Answers what is pending; returns the names of the parameters set.
    pub fn serve(&mut self, node: &Node, p: &mut Params, now: Instant) -> Vec<String> {
        let mut changed = Vec::new();
        self.list.serve(node, now, |r| list(p, &r));
        self.get.serve(node, now, |r| get(p, &r));
        self.get_types.serve(node, now, |r| get_types(p, &r));
        self.describe.serve(node, now, |r| describe_params(p, &r));
        self.set.serve(node, now, |r| set(p, &r, &mut changed));
        self.set_atomically
            .serve(node, now, |r| set_atomically(p, &r, &mut changed));
        if !changed.is_empty() {
            let sent = self.events.publish(raw::ParameterEvent {
                stamp: ros2_client::builtin_interfaces::Time::now(),
                node: self.node_fqn.clone(),
                new_parameters: Vec::new(),
                changed_parameters: changed
                    .iter()
                    .filter_map(|n| {
                        p.get(n).map(|v| raw::Parameter {
                            name: n.clone(),
                            value: to_raw(v),
                        })
                    })
                    .collect(),
                deleted_parameters: Vec::new(),
            });
            if let Err(e) = sent {
                super::log::node_log!(
                    Warn,
                    "/parameter_events: the change was not announced: {e:?}"
                );
            }
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::params::*;

    fn params() -> Params {
        Params::new(vec![
            (RTF, ParamValue::Double(1.0)),
            (RATE_HZ, ParamValue::Double(20.0)),
            (MARKER_RATE_HZ, ParamValue::Double(5.0)),
            (LOCK_PERIOD_S, ParamValue::Double(1.0)),
            (MAX_SPEED_M_S, ParamValue::Double(1.0)),
            (MODEL, ParamValue::Str("m.toml".into())),
            (FRAME_ID, ParamValue::Str("truss".into())),
            (PARENT_FRAME_ID, ParamValue::Str("world".into())),
            (PUBLISH_CLOCK, ParamValue::Bool(true)),
            (USE_SIM_TIME, ParamValue::Bool(false)),
            (TF_FRAMES, ParamValue::StrArray(vec!["L4".into()])),
        ])
        .unwrap()
    }

    fn param(name: &str, v: ParamValue) -> raw::Parameter {
        raw::Parameter {
            name: name.into(),
            value: to_raw(&v),
        }
    }

    #[test]
    fn list_get_describe_set() {
        let mut p = params();
        let l = list(
            &p,
            &ListParametersRequest {
                prefixes: vec![],
                depth: 0,
            },
        );
        assert!(l.result.names.contains(&"rtf".to_string()) && l.result.names.len() == 11);
        let g = get(
            &p,
            &GetParametersRequest {
                names: vec!["rtf".into(), "nope".into(), "tf_frames".into()],
            },
        );
        assert_eq!(g.values[0].ptype, raw::ParameterType::DOUBLE);
        assert_eq!(g.values[0].double_value, 1.0);
        assert_eq!(g.values[1].ptype, raw::ParameterType::NOT_SET);
        assert_eq!(g.values[2].string_array, ["L4"]);
        let d = describe_params(
            &p,
            &DescribeParametersRequest {
                names: vec!["rtf".into(), "model".into()],
            },
        );
        assert_eq!(d.values[0].floating_point_range[0].to_value, 1000.0);
        assert!(d.values[1].read_only && !d.values[0].read_only);
        let mut changed = Vec::new();
        let s = set(
            &mut p,
            &SetParametersRequest {
                parameter: vec![
                    param("rtf", ParamValue::Double(2.0)),
                    param("rtf", ParamValue::Double(-1.0)),
                    param("model", ParamValue::Str("x".into())),
                    param("rate_hz", ParamValue::Int(10)),
                ],
            },
            &mut changed,
        );
        let ok: Vec<bool> = s.results.iter().map(|r| r.successful).collect();
        assert_eq!(ok, [true, false, false, true]);
        assert!(s.results[1].reason.contains("outside its range"));
        assert!(s.results[2].reason.contains("read-only"));
        assert_eq!((p.f64(RTF), p.f64(RATE_HZ)), (2.0, 10.0));
        assert_eq!(changed, ["rtf", "rate_hz"]);
        // atomically: one bad value refuses all
        let mut changed = Vec::new();
        let a = set_atomically(
            &mut p,
            &SetParametersRequest {
                parameter: vec![
                    param("rtf", ParamValue::Double(3.0)),
                    param("lock_period_s", ParamValue::Double(0.0)),
                ],
            },
            &mut changed,
        );
        assert!(!a.result.successful && a.result.reason.contains("lock_period_s"));
        assert_eq!(p.f64(RTF), 2.0);
        assert!(changed.is_empty());
    }
}
