//! ROS 2 command-line arguments (rcl's `--ros-args` syntax), pure and without
//! DDS: `-r/--remap [NODE:]FROM:=TO` (topics and services, `__node`/`__name`,
//! `__ns`), `-p/--param [NODE:]NAME:=VALUE`, `--params-file FILE` (the ROS 2
//! YAML layout `node: ros__parameters: ...`, with `/**` wildcards), and
//! `--log-level [LOGGER:=]LEVEL`. A `--ros-args` section ends at `--` or at
//! the end of the command line; there may be several.

use std::ffi::OsString;
use std::path::Path;

/// A parameter value as ROS 2 types it (rcl_interfaces/ParameterType).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Bool(bool),
    Int(i64),
    Double(f64),
    Str(String),
    BoolArray(Vec<bool>),
    IntArray(Vec<i64>),
    DoubleArray(Vec<f64>),
    StrArray(Vec<String>),
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Bool(b) => write!(f, "{b}"),
            ParamValue::Int(i) => write!(f, "{i}"),
            ParamValue::Double(d) => write!(f, "{d}"),
            ParamValue::Str(s) => write!(f, "'{s}'"),
            ParamValue::BoolArray(v) => write!(f, "{v:?}"),
            ParamValue::IntArray(v) => write!(f, "{v:?}"),
            ParamValue::DoubleArray(v) => write!(f, "{v:?}"),
            ParamValue::StrArray(v) => write!(f, "{v:?}"),
        }
    }
}

/// Severity of a log line: rcl_interfaces/msg/Log's levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LogLevel {
    Debug = 10,
    Info = 20,
    Warn = 30,
    Error = 40,
    Fatal = 50,
}

impl LogLevel {
    pub fn parse(s: &str) -> Option<LogLevel> {
        match s.to_ascii_lowercase().as_str() {
            "debug" => Some(LogLevel::Debug),
            "info" => Some(LogLevel::Info),
            "warn" | "warning" => Some(LogLevel::Warn),
            "error" => Some(LogLevel::Error),
            "fatal" => Some(LogLevel::Fatal),
            _ => None,
        }
    }
}

/// `-r [NODE:]FROM:=TO`.
#[derive(Clone, Debug, PartialEq)]
pub struct Remap {
    /// Applies only to the node of this name (None: to every node).
    pub node: Option<String>,
    pub from: String,
    pub to: String,
}

/// One parameter assignment, with where it came from (for error messages).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamAssign {
    /// Node pattern: None for every node; `-p NODE:NAME:=V` gives the node
    /// name, a params file its key path (`/**`, `/ns/node`, `node`, ...).
    pub node: Option<String>,
    pub name: String,
    pub value: ParamValue,
    /// `-p ...` or `--params-file FILE line N (NODE)`.
    pub origin: String,
    /// Given with `-p` (an unknown name is then an error, while a params file
    /// may hold other nodes' parameters).
    pub from_command_line: bool,
}

/// Everything given in `--ros-args` sections, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    pub remaps: Vec<Remap>,
    /// `--params-file` and `-p` in the order given: the last one wins.
    pub params: Vec<ParamAssign>,
    pub log_level: Option<LogLevel>,
}

/// Splits a command line into the program's own arguments and the contents
/// of its `--ros-args` sections (each ends at `--` or the end).
pub fn split_argv(argv: impl IntoIterator<Item = OsString>) -> (Vec<OsString>, Vec<OsString>) {
    let (mut own, mut ros) = (Vec::new(), Vec::new());
    let mut in_ros = false;
    for a in argv {
        if a == "--ros-args" {
            in_ros = true;
        } else if in_ros && a == "--" {
            in_ros = false;
        } else if in_ros {
            ros.push(a);
        } else {
            own.push(a);
        }
    }
    (own, ros)
}

/// Parses the contents of `--ros-args` sections (as [`split_argv`] returns them).
pub fn parse(args: &[OsString]) -> Result<RosArgs, String> {
    let mut out = RosArgs::default();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let a = a
            .to_str()
            .ok_or_else(|| format!("--ros-args: `{}` is not UTF-8", a.to_string_lossy()))?;
        let mut value = |flag: &str| -> Result<String, String> {
            it.next()
                .and_then(|v| v.to_str().map(str::to_string))
                .ok_or_else(|| format!("--ros-args: {flag} needs a value"))
        };
        match a {
            "-r" | "--remap" => {
                let rule = value(a)?;
                out.remaps.push(parse_remap(&rule)?);
            }
            "-p" | "--param" => {
                let rule = value(a)?;
                out.params.push(parse_param_rule(&rule)?);
            }
            "--params-file" => {
                let file = value(a)?;
                out.params.extend(read_params_file(Path::new(&file))?);
            }
            "--log-level" => {
                let v = value(a)?;
                // `LOGGER:=LEVEL` sets one logger; this node has one.
                let level = v.rsplit(":=").next().unwrap_or(&v);
                out.log_level = Some(LogLevel::parse(level).ok_or_else(|| {
                    format!(
                        "--ros-args --log-level `{v}`: the level must be debug, info, warn, error or fatal"
                    )
                })?);
            }
            // Accepted and without effect here: logs always go to stdout/stderr
            // and /rosout; no security enclaves.
            "--enable-rosout-logs" | "--disable-rosout-logs" | "--enable-stdout-logs"
            | "--disable-stdout-logs" | "--enable-external-lib-logs"
            | "--disable-external-lib-logs" => {}
            "-e" | "--enclave" | "--log-file-name" | "--log-config-file" => {
                value(a)?;
            }
            other => {
                return Err(format!(
                    "--ros-args: unknown argument `{other}` (known: -r/--remap FROM:=TO, -p/--param NAME:=VALUE, \
                     --params-file FILE, --log-level LEVEL; a section ends at `--`)"
                ))
            }
        }
    }
    Ok(out)
}

/// `[NODE:]FROM:=TO`.
fn parse_remap(rule: &str) -> Result<Remap, String> {
    let bad = |why: &str| format!("--ros-args -r `{rule}`: {why} (form: [NODE:]FROM:=TO)");
    let (lhs, to) = rule.split_once(":=").ok_or_else(|| bad("no `:=`"))?;
    let (node, from) = match lhs.split_once(':') {
        Some((n, f)) => (Some(n.to_string()), f),
        None => (None, lhs),
    };
    if from.is_empty() || to.is_empty() {
        return Err(bad("empty name"));
    }
    let from = if from == "__name" { "__node" } else { from };
    if from.starts_with("__") && from != "__node" && from != "__ns" {
        return Err(bad("only __node (__name) and __ns are special"));
    }
    Ok(Remap {
        node,
        from: from.to_string(),
        to: to.to_string(),
    })
}

/// `[NODE:]NAME:=VALUE` (VALUE in YAML).
fn parse_param_rule(rule: &str) -> Result<ParamAssign, String> {
    let bad = |why: String| format!("--ros-args -p `{rule}`: {why} (form: NAME:=VALUE)");
    let (lhs, v) = rule.split_once(":=").ok_or_else(|| bad("no `:=`".into()))?;
    // `NODE:NAME`: the node of that name in any namespace.
    let (node, name) = match lhs.split_once(':') {
        Some((n, p)) => (Some(format!("/**/{n}")), p),
        None => (None, lhs),
    };
    if name.is_empty() {
        return Err(bad("empty name".into()));
    }
    let value = yaml_value(v).map_err(bad)?;
    Ok(ParamAssign {
        node,
        name: name.to_string(),
        value,
        origin: format!("-p {rule}"),
        from_command_line: true,
    })
}

/// One YAML value of a parameter: a scalar or a flow sequence `[a, b]`.
pub fn yaml_value(v: &str) -> Result<ParamValue, String> {
    let v = v.trim();
    if let Some(inner) = v.strip_prefix('[') {
        let inner = inner
            .strip_suffix(']')
            .ok_or_else(|| format!("`{v}`: a sequence ends with `]`"))?;
        let items: Vec<Scalar> = split_flow(inner)?.iter().map(|s| scalar(s)).collect();
        return array(items).map_err(|e| format!("`{v}`: {e}"));
    }
    if v.starts_with('{') {
        return Err(format!("`{v}`: a map is not a parameter value"));
    }
    Ok(scalar(v).into_value())
}

/// A YAML scalar as YAML types it (quoted: always a string).
#[derive(Clone, Debug, PartialEq)]
enum Scalar {
    Bool(bool),
    Int(i64),
    Double(f64),
    Str(String),
}

impl Scalar {
    fn into_value(self) -> ParamValue {
        match self {
            Scalar::Bool(b) => ParamValue::Bool(b),
            Scalar::Int(i) => ParamValue::Int(i),
            Scalar::Double(d) => ParamValue::Double(d),
            Scalar::Str(s) => ParamValue::Str(s),
        }
    }
}

fn scalar(s: &str) -> Scalar {
    let s = s.trim();
    for q in ['"', '\''] {
        if s.len() >= 2 && s.starts_with(q) && s.ends_with(q) {
            return Scalar::Str(s[1..s.len() - 1].to_string());
        }
    }
    match s {
        "true" | "True" | "TRUE" | "yes" | "Yes" | "YES" | "on" | "On" | "ON" => {
            return Scalar::Bool(true)
        }
        "false" | "False" | "FALSE" | "no" | "No" | "NO" | "off" | "Off" | "OFF" => {
            return Scalar::Bool(false)
        }
        ".inf" | "+.inf" | ".Inf" | ".INF" => return Scalar::Double(f64::INFINITY),
        "-.inf" | "-.Inf" | "-.INF" => return Scalar::Double(f64::NEG_INFINITY),
        ".nan" | ".NaN" | ".NAN" => return Scalar::Double(f64::NAN),
        _ => {}
    }
    if let Ok(i) = s.parse::<i64>() {
        return Scalar::Int(i);
    }
    let numeric = s
        .chars()
        .all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'))
        && s.chars().any(|c| c.is_ascii_digit());
    if numeric {
        if let Ok(d) = s.parse::<f64>() {
            return Scalar::Double(d);
        }
    }
    Scalar::Str(s.to_string())
}

/// Items of a flow sequence's inside, split at commas outside quotes.
fn split_flow(inner: &str) -> Result<Vec<String>, String> {
    let mut items = Vec::new();
    let mut cur = String::new();
    let mut quote: Option<char> = None;
    for c in inner.chars() {
        match (quote, c) {
            (None, '"' | '\'') => {
                quote = Some(c);
                cur.push(c);
            }
            (Some(q), _) if c == q => {
                quote = None;
                cur.push(c);
            }
            (None, ',') => items.push(std::mem::take(&mut cur)),
            (None, '[' | '{') => {
                return Err("nested sequences or maps are not parameter values".into())
            }
            _ => cur.push(c),
        }
    }
    if quote.is_some() {
        return Err("unclosed quote".into());
    }
    if !cur.trim().is_empty() || !items.is_empty() {
        items.push(cur);
    }
    Ok(items)
}

/// A homogeneous array (integers among doubles count as doubles).
fn array(items: Vec<Scalar>) -> Result<ParamValue, String> {
    if items.is_empty() {
        // ROS 2 cannot type an empty list either; a string array is the useful one here.
        return Ok(ParamValue::StrArray(Vec::new()));
    }
    let all = |f: fn(&Scalar) -> bool| items.iter().all(f);
    if all(|s| matches!(s, Scalar::Bool(_))) {
        Ok(ParamValue::BoolArray(
            items
                .iter()
                .map(|s| matches!(s, Scalar::Bool(true)))
                .collect(),
        ))
    } else if all(|s| matches!(s, Scalar::Int(_))) {
        Ok(ParamValue::IntArray(
            items
                .iter()
                .map(|s| if let Scalar::Int(i) = s { *i } else { 0 })
                .collect(),
        ))
    } else if all(|s| matches!(s, Scalar::Int(_) | Scalar::Double(_))) {
        Ok(ParamValue::DoubleArray(
            items
                .iter()
                .map(|s| match s {
                    Scalar::Int(i) => *i as f64,
                    Scalar::Double(d) => *d,
                    _ => 0.0,
                })
                .collect(),
        ))
    } else if all(|s| matches!(s, Scalar::Str(_))) {
        Ok(ParamValue::StrArray(
            items
                .into_iter()
                .map(|s| {
                    if let Scalar::Str(x) = s {
                        x
                    } else {
                        String::new()
                    }
                })
                .collect(),
        ))
    } else {
        Err("the items of an array must all have one type".into())
    }
}

/// A block YAML node of a params file.
#[derive(Debug)]
enum Yaml {
    Map(Vec<(String, Yaml, usize)>),
    Seq(Vec<String>),
    Value(String),
}

/// The ROS 2 parameters file layout: node keys (nested keys join into a
/// namespace path) down to `ros__parameters:`, under which nested keys join
/// into dotted parameter names.
pub fn read_params_file(path: &Path) -> Result<Vec<ParamAssign>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("--params-file {}: {e}", path.display()))?;
    parse_params_yaml(&text, &path.display().to_string())
}

pub fn parse_params_yaml(text: &str, file: &str) -> Result<Vec<ParamAssign>, String> {
    let lines = yaml_lines(text, file)?;
    let mut pos = 0;
    let root = block(&lines, &mut pos, 0, file)?;
    if pos < lines.len() {
        return Err(format!(
            "--params-file {file} line {}: indentation does not fit the lines before",
            lines[pos].0
        ));
    }
    let mut out = Vec::new();
    let Yaml::Map(entries) = root else {
        return Err(format!(
            "--params-file {file}: expected `NODE: ros__parameters: ...` at the top"
        ));
    };
    for (k, v, line) in entries {
        walk_nodes(&k, v, line, file, &mut out)?;
    }
    Ok(out)
}

fn walk_nodes(
    path: &str,
    y: Yaml,
    line: usize,
    file: &str,
    out: &mut Vec<ParamAssign>,
) -> Result<(), String> {
    let Yaml::Map(entries) = y else {
        return Err(format!(
            "--params-file {file} line {line}: `{path}` needs `ros__parameters:` under it"
        ));
    };
    for (k, v, l) in entries {
        if k == "ros__parameters" {
            walk_params(path, "", v, l, file, out)?;
        } else {
            let p = format!(
                "{}/{}",
                path.trim_end_matches('/'),
                k.trim_start_matches('/')
            );
            walk_nodes(&p, v, l, file, out)?;
        }
    }
    Ok(())
}

fn walk_params(
    node: &str,
    prefix: &str,
    y: Yaml,
    line: usize,
    file: &str,
    out: &mut Vec<ParamAssign>,
) -> Result<(), String> {
    let at = |l: usize| format!("--params-file {file} line {l}");
    match y {
        Yaml::Map(entries) => {
            for (k, v, l) in entries {
                let name = if prefix.is_empty() {
                    k
                } else {
                    format!("{prefix}.{k}")
                };
                walk_params(node, &name, v, l, file, out)?;
            }
            Ok(())
        }
        Yaml::Value(v) => {
            if prefix.is_empty() {
                return Err(format!("{}: ros__parameters must hold a map", at(line)));
            }
            let value = yaml_value(&v).map_err(|e| format!("{}: {e}", at(line)))?;
            out.push(ParamAssign {
                node: Some(node.to_string()),
                name: prefix.to_string(),
                value,
                origin: format!("{} ({node})", at(line)),
                from_command_line: false,
            });
            Ok(())
        }
        Yaml::Seq(items) => {
            let value = array(items.iter().map(|s| scalar(s)).collect())
                .map_err(|e| format!("{}: {e}", at(line)))?;
            out.push(ParamAssign {
                node: Some(node.to_string()),
                name: prefix.to_string(),
                value,
                origin: format!("{} ({node})", at(line)),
                from_command_line: false,
            });
            Ok(())
        }
    }
}

/// (line number, indentation, content) of the lines that matter.
fn yaml_lines(text: &str, file: &str) -> Result<Vec<(usize, usize, String)>, String> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        if raw.contains('\t') && raw.trim_start().len() < raw.len() && raw.starts_with('\t') {
            return Err(format!(
                "--params-file {file} line {}: tabs do not indent YAML",
                i + 1
            ));
        }
        let content = strip_comment(raw);
        let t = content.trim_end();
        if t.trim().is_empty() || t == "---" || t == "..." {
            continue;
        }
        let indent = t.len() - t.trim_start().len();
        out.push((i + 1, indent, t.trim_start().to_string()));
    }
    Ok(out)
}

fn strip_comment(line: &str) -> &str {
    let mut quote: Option<char> = None;
    let mut prev_space = true;
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, '#') if prev_space => return &line[..i],
            _ => {}
        }
        prev_space = c.is_whitespace();
    }
    line
}

/// The block starting at lines[*pos] with indentation >= `min`.
fn block(
    lines: &[(usize, usize, String)],
    pos: &mut usize,
    min: usize,
    file: &str,
) -> Result<Yaml, String> {
    let Some((_, indent, first)) = lines.get(*pos) else {
        return Ok(Yaml::Map(Vec::new()));
    };
    let indent = *indent;
    if indent < min {
        return Ok(Yaml::Map(Vec::new()));
    }
    if first.starts_with("- ") || first == "-" {
        let mut items = Vec::new();
        while let Some((l, i, c)) = lines.get(*pos) {
            if *i != indent || !(c.starts_with("- ") || c == "-") {
                break;
            }
            let item = c[1..].trim();
            if item.ends_with(':') || item.starts_with('[') || item.starts_with('{') {
                return Err(format!(
                    "--params-file {file} line {l}: a list item must be a scalar"
                ));
            }
            items.push(item.to_string());
            *pos += 1;
        }
        return Ok(Yaml::Seq(items));
    }
    let mut entries = Vec::new();
    while let Some((l, i, c)) = lines.get(*pos) {
        let (l, i) = (*l, *i);
        if i < indent {
            break;
        }
        if i > indent {
            return Err(format!(
                "--params-file {file} line {l}: unexpected indentation"
            ));
        }
        let (key, rest) = split_key(c).ok_or_else(|| {
            format!("--params-file {file} line {l}: expected `KEY: VALUE` or `KEY:`")
        })?;
        *pos += 1;
        let value = if rest.is_empty() {
            match lines.get(*pos) {
                Some((_, ni, _)) if *ni > indent => block(lines, pos, indent + 1, file)?,
                // a list may sit at its key's indentation (as PyYAML writes it)
                Some((_, ni, nc)) if *ni == indent && (nc.starts_with("- ") || nc == "-") => {
                    block(lines, pos, indent, file)?
                }
                _ => {
                    return Err(format!(
                        "--params-file {file} line {l}: `{key}:` has no value"
                    ))
                }
            }
        } else if rest.starts_with('{') {
            if rest.trim() == "{}" {
                Yaml::Map(Vec::new())
            } else {
                return Err(format!(
                    "--params-file {file} line {l}: flow maps {{...}} are not supported; write one key per line"
                ));
            }
        } else {
            Yaml::Value(rest.to_string())
        };
        entries.push((key, value, l));
    }
    Ok(Yaml::Map(entries))
}

/// `key: rest` (key possibly quoted) or None.
fn split_key(c: &str) -> Option<(String, String)> {
    let (key, rest) = if let Some(q) = c.chars().next().filter(|q| *q == '"' || *q == '\'') {
        let end = c[1..].find(q)? + 1;
        let rest = c[end + 1..].trim_start().strip_prefix(':')?;
        (c[1..end].to_string(), rest)
    } else {
        let i = c
            .find(": ")
            .or_else(|| c.strip_suffix(':').map(|s| s.len()))?;
        (c[..i].trim().to_string(), &c[i + 1..])
    };
    Some((key, rest.trim().to_string()))
}

/// Whether a params-file node key (`/**`, `/**/name`, `/ns/name`, `name`,
/// with `*` for one token) selects the node `fqn` (`/ns/name`).
pub fn node_pattern_matches(pattern: &str, fqn: &str) -> bool {
    let pat = if pattern.starts_with('/') {
        pattern.to_string()
    } else {
        format!("/{pattern}")
    };
    let p: Vec<&str> = pat.split('/').filter(|s| !s.is_empty()).collect();
    let n: Vec<&str> = fqn.split('/').filter(|s| !s.is_empty()).collect();
    fn m(p: &[&str], n: &[&str]) -> bool {
        match (p.first(), n.first()) {
            (None, None) => true,
            (Some(&"**"), _) => m(&p[1..], n) || (!n.is_empty() && m(p, &n[1..])),
            (Some(&"*"), Some(_)) => m(&p[1..], &n[1..]),
            (Some(a), Some(b)) if a == b => m(&p[1..], &n[1..]),
            _ => false,
        }
    }
    m(&p, &n)
}

impl RosArgs {
    /// Rules for this node (those without a node prefix, or naming `node`).
    fn remaps_for<'a>(&'a self, node: &'a str) -> impl Iterator<Item = &'a Remap> + 'a {
        self.remaps
            .iter()
            .filter(move |r| r.node.as_deref().is_none_or(|n| n == node))
    }

    /// The node name: `-r __node:=NAME` (the first rule that applies, as rcl), else `default`.
    pub fn node_name(&self, default: &str) -> Result<String, String> {
        match self.remaps_for(default).find(|r| r.from == "__node") {
            None => Ok(default.to_string()),
            Some(r) => {
                let ok =
                    r.to.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
                        && r.to.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
                if ok {
                    Ok(r.to.clone())
                } else {
                    Err(format!(
                        "--ros-args -r __node:={}: a node name is letters, digits and `_`, not starting with a digit",
                        r.to
                    ))
                }
            }
        }
    }

    /// The namespace of `-r __ns:=NS`, if given.
    pub fn namespace(&self, node: &str) -> Option<String> {
        self.remaps_for(node)
            .find(|r| r.from == "__ns")
            .map(|r| r.to.clone())
    }

    /// Topic and service remappings (FROM, TO) for the node `node` in `ns`,
    /// both resolved to absolute names.
    pub fn name_remaps(&self, node: &str, ns: &str) -> Result<Vec<(String, String)>, String> {
        self.remaps_for(node)
            .filter(|r| !r.from.starts_with("__"))
            .map(|r| Ok((resolve(&r.from, ns, node)?, resolve(&r.to, ns, node)?)))
            .collect()
    }

    /// The parameter assignments that apply to the node `fqn`, in order.
    pub fn params_for<'a>(&'a self, fqn: &'a str) -> impl Iterator<Item = &'a ParamAssign> + 'a {
        self.params.iter().filter(move |p| match &p.node {
            None => true,
            Some(pat) => node_pattern_matches(pat, fqn),
        })
    }
}

/// An absolute name from a name relative to `ns` (or `~/x`, private to the node).
pub fn resolve(name: &str, ns: &str, node: &str) -> Result<String, String> {
    let base = ns.trim_end_matches('/');
    let full = if let Some(rest) = name.strip_prefix("~/") {
        format!("{base}/{node}/{rest}")
    } else if name == "~" {
        format!("{base}/{node}")
    } else if name.starts_with('/') {
        name.to_string()
    } else {
        format!("{base}/{name}")
    };
    let ok = full.len() > 1
        && !full.ends_with('/')
        && full.split('/').skip(1).all(|t| {
            t.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
                && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && !t.contains("__")
        });
    if ok {
        Ok(full)
    } else {
        Err(format!(
            "name `{name}` (resolved `{full}`): each token must be letters, digits and single `_`, not starting with a digit"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn os(v: &[&str]) -> Vec<OsString> {
        v.iter().map(OsString::from).collect()
    }

    #[test]
    fn sections_end_at_double_dash_or_the_end() {
        let (own, ros) = split_argv(os(&[
            "x",
            "node",
            "m.toml",
            "--ros-args",
            "-r",
            "a:=b",
            "--",
            "--rtf",
            "2",
            "--ros-args",
            "-p",
            "rtf:=3",
        ]));
        assert_eq!(own, os(&["x", "node", "m.toml", "--rtf", "2"]));
        assert_eq!(ros, os(&["-r", "a:=b", "-p", "rtf:=3"]));
    }

    #[test]
    fn remaps_params_and_log_level() {
        let a = parse(&os(&[
            "-r",
            "/joint_states:=/truss/js",
            "-r",
            "__node:=t2",
            "-r",
            "other:__ns:=/x",
            "--remap",
            "__ns:=/robot",
            "-p",
            "rtf:=2.0",
            "-p",
            "t2:tf_frames:=[a, 'b']",
            "--log-level",
            "WARN",
        ]))
        .unwrap();
        assert_eq!(a.node_name("truss_deploy").unwrap(), "t2");
        assert_eq!(a.namespace("truss_deploy").as_deref(), Some("/robot"));
        assert_eq!(
            a.name_remaps("truss_deploy", "/robot").unwrap(),
            [("/joint_states".to_string(), "/truss/js".to_string())]
        );
        assert_eq!(a.params[0].value, ParamValue::Double(2.0));
        assert_eq!(
            a.params[1].value,
            ParamValue::StrArray(vec!["a".into(), "b".into()])
        );
        assert_eq!(a.params_for("/robot/t2").count(), 2);
        assert_eq!(a.params_for("/robot/t3").count(), 1);
        assert_eq!(a.log_level, Some(LogLevel::Warn));
    }

    #[test]
    fn bad_arguments_say_what() {
        for (args, says) in [
            (&["-r"][..], "-r needs a value"),
            (&["-r", "abc"], "no `:=`"),
            (&["-r", "__foo:=x"], "__node"),
            (&["-p", "rtf"], "no `:=`"),
            (&["-p", "x:=[1, a]"], "one type"),
            (&["--log-level", "loud"], "debug, info"),
            (&["--frobnicate"], "unknown argument `--frobnicate`"),
            (
                &["--params-file", "/nonexistent/p.yaml"],
                "/nonexistent/p.yaml",
            ),
        ] {
            let e = parse(&os(args)).unwrap_err();
            assert!(e.contains(says), "{args:?}: {e}");
        }
        let a = parse(&os(&["-r", "__node:=9x"])).unwrap();
        assert!(a.node_name("n").is_err());
        let a = parse(&os(&["-r", "a:=b c"])).unwrap();
        assert!(a.name_remaps("n", "/").is_err());
    }

    #[test]
    fn params_file_layout() {
        let y = "\
# comment
/**:
  ros__parameters:
    rtf: 2   # an int
    names: [\"a\", b]
t2:
  ros__parameters:
    rate_hz: 10.5
    nested:
      deep: 'x: y'
/robot:
  t2:
    ros__parameters:
      lock_period_s: 0.5
      frames:
        - tip
        - base
other_node:
  ros__parameters:
    rtf: 9.0
    frames:
    - a
    - b
    after: 1
";
        let p = parse_params_yaml(y, "p.yaml").unwrap();
        let got: Vec<(String, String, ParamValue)> = p
            .iter()
            .map(|a| (a.node.clone().unwrap(), a.name.clone(), a.value.clone()))
            .collect();
        assert_eq!(got[0], ("/**".into(), "rtf".into(), ParamValue::Int(2)));
        assert_eq!(got[1].2, ParamValue::StrArray(vec!["a".into(), "b".into()]));
        assert_eq!(
            got[2],
            ("t2".into(), "rate_hz".into(), ParamValue::Double(10.5))
        );
        assert_eq!(
            got[3],
            (
                "t2".into(),
                "nested.deep".into(),
                ParamValue::Str("x: y".into())
            )
        );
        assert_eq!(got[4].0, "/robot/t2");
        assert_eq!(
            got[5].2,
            ParamValue::StrArray(vec!["tip".into(), "base".into()])
        );
        assert_eq!(
            (&got[7].1, &got[7].2, &got[8].1),
            (
                &"frames".to_string(),
                &ParamValue::StrArray(vec!["a".into(), "b".into()]),
                &"after".to_string()
            ),
            "a list at its key's indentation"
        );
        let ra = RosArgs {
            params: p,
            ..Default::default()
        };
        let names: Vec<&str> = ra
            .params_for("/robot/t2")
            .map(|a| a.name.as_str())
            .collect();
        assert_eq!(names, ["rtf", "names", "lock_period_s", "frames"]);
        let names: Vec<&str> = ra.params_for("/t2").map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["rtf", "names", "rate_hz", "nested.deep"]);
        for (bad, says) in [
            ("a:\n  b: 1\n", "ros__parameters"),
            ("n:\n  ros__parameters:\n    x: {a: 1}\n", "flow maps"),
            ("n:\n  ros__parameters:\n      x: 1\n    y: 2\n", "line 4"),
            ("n:\n  ros__parameters:\n    x:\n", "line 3"),
        ] {
            let e = parse_params_yaml(bad, "f.yaml").unwrap_err();
            assert!(e.contains(says) && e.contains("f.yaml"), "{bad:?}: {e}");
        }
    }

    #[test]
    fn node_patterns() {
        assert!(node_pattern_matches("/**", "/a/b/n"));
        assert!(node_pattern_matches("/**/n", "/a/n"));
        assert!(node_pattern_matches("n", "/n"));
        assert!(!node_pattern_matches("n", "/a/n"));
        assert!(node_pattern_matches("/a/*", "/a/n"));
        assert!(!node_pattern_matches("/b/n", "/a/n"));
    }

    #[test]
    fn resolving_names() {
        assert_eq!(resolve("js", "/r", "n").unwrap(), "/r/js");
        assert_eq!(resolve("/js", "/r", "n").unwrap(), "/js");
        assert_eq!(resolve("~/x", "/", "n").unwrap(), "/n/x");
        assert!(resolve("a//b", "/", "n").is_err());
    }
}
