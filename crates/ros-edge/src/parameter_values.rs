//! A binary's parameter struct as ROS 2 parameters, so that `ros2 param list`, `get` and `dump`
//! show what it runs with, as they show any rclcpp node's: a dotted name for each leaf of the
//! struct as its parameter file nests it (`limits.max_linear`), with the ROS type of its value.

use ros2_client::ParameterValue;
use serde::Serialize;
use serde_yaml::Value;

/// Every leaf of `params` (serialised as its parameter file would hold it), by dotted name, as
/// the ROS parameter it is: a bool, an integer, a double, a string, or a list of one of those.
/// A value no ROS parameter can hold (a null, a list of mixed or nested values, a list of maps)
/// is left out, as rclcpp would refuse to declare it.
pub fn flatten<T: Serialize>(params: &T) -> Vec<(String, ParameterValue)> {
    let mut out = Vec::new();
    if let Ok(Value::Mapping(m)) = serde_yaml::to_value(params) {
        walk("", &Value::Mapping(m), &mut out);
    }
    out
}

fn walk(prefix: &str, value: &Value, out: &mut Vec<(String, ParameterValue)>) {
    match value {
        Value::Mapping(m) => {
            for (key, v) in m {
                let Some(key) = key.as_str() else { continue };
                let name = match prefix {
                    "" => key.to_owned(),
                    _ => format!("{prefix}.{key}"),
                };
                walk(&name, v, out);
            }
        }
        Value::Tagged(t) => walk(prefix, &t.value, out),
        leaf => {
            if let Some(v) = parameter_value(leaf) {
                out.push((prefix.to_owned(), v));
            }
        }
    }
}

/// The validator's answer for a parameter declared read-only from `held` (what [`flatten`]
/// gave): `None` when `name` is not one of them; else the value held is accepted (declaring it
/// passes the validator too, and setting it again changes nothing) and any other refused,
/// saying how to change it (`who` restarts: "the node"). NaN is its own value here, so that a
/// NaN held can be declared.
pub fn read_only_answer(
    held: &[(String, ParameterValue)],
    name: &str,
    value: &ParameterValue,
    who: &str,
) -> Option<Result<(), String>> {
    let (_, v) = held.iter().find(|(n, _)| n == name)?;
    Some(if same(v, value) {
        Ok(())
    } else {
        Err(format!(
            "`{name}` is read at start only: set it in the parameter file or with -p and restart {who}"
        ))
    })
}

/// Equal values, a NaN equal to a NaN.
fn same(a: &ParameterValue, b: &ParameterValue) -> bool {
    let eq = |x: &f64, y: &f64| x == y || (x.is_nan() && y.is_nan());
    match (a, b) {
        (ParameterValue::Double(x), ParameterValue::Double(y)) => eq(x, y),
        (ParameterValue::DoubleArray(xs), ParameterValue::DoubleArray(ys)) => {
            xs.len() == ys.len() && xs.iter().zip(ys).all(|(x, y)| eq(x, y))
        }
        _ => a == b,
    }
}

/// A YAML scalar or list as the ROS parameter value it is, if it is one. A list of whole and
/// fractional numbers (`initial_pose: [0.1, 0.1, 0]`) is a list of doubles.
fn parameter_value(value: &Value) -> Option<ParameterValue> {
    let Value::Sequence(items) = value else {
        return match value {
            Value::Bool(b) => Some(ParameterValue::Boolean(*b)),
            Value::Number(n) => match n.as_i64() {
                Some(i) => Some(ParameterValue::Integer(i)),
                None => n.as_f64().map(ParameterValue::Double),
            },
            Value::String(s) => Some(ParameterValue::String(s.clone())),
            _ => None,
        };
    };
    let all = |kind: fn(&Value) -> bool| !items.is_empty() && items.iter().all(kind);
    if all(Value::is_bool) {
        Some(ParameterValue::BooleanArray(
            items.iter().filter_map(Value::as_bool).collect(),
        ))
    } else if all(Value::is_i64) {
        Some(ParameterValue::IntegerArray(
            items.iter().filter_map(Value::as_i64).collect(),
        ))
    } else if all(Value::is_number) {
        Some(ParameterValue::DoubleArray(
            items.iter().filter_map(Value::as_f64).collect(),
        ))
    } else if all(Value::is_string) {
        let strings = items.iter().filter_map(|v| v.as_str().map(String::from));
        Some(ParameterValue::StringArray(strings.collect()))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Params {
        backend: &'static str,
        publish_tf: bool,
        rate_hz: f64,
        limits: Limits,
        initial_pose: [f64; 3],
        baud: u32,
        names: Vec<&'static str>,
        nothing: Option<f64>,
        mixed: (i32, &'static str),
    }

    #[derive(Serialize)]
    struct Limits {
        max_linear: f64,
    }

    #[test]
    fn every_leaf_by_its_dotted_name_and_ros_type() {
        let p = Params {
            backend: "sim",
            publish_tf: true,
            rate_hz: 50.0,
            limits: Limits { max_linear: 0.6 },
            initial_pose: [0.1, 0.1, 0.0],
            baud: 115_200,
            names: vec!["a", "b"],
            nothing: None,
            mixed: (1, "x"),
        };
        let got = flatten(&p);
        let expect = [
            ("backend", ParameterValue::String("sim".into())),
            ("publish_tf", ParameterValue::Boolean(true)),
            ("rate_hz", ParameterValue::Double(50.0)),
            ("limits.max_linear", ParameterValue::Double(0.6)),
            (
                "initial_pose",
                ParameterValue::DoubleArray(vec![0.1, 0.1, 0.0]),
            ),
            ("baud", ParameterValue::Integer(115_200)),
            (
                "names",
                ParameterValue::StringArray(vec!["a".into(), "b".into()]),
            ),
        ];
        let expect: Vec<(String, ParameterValue)> =
            expect.into_iter().map(|(n, v)| (n.to_owned(), v)).collect();
        // The null and the mixed list are no ROS parameters: left out.
        assert_eq!(got, expect);
    }

    /// The value held passes (a NaN too: declaring it must), another is refused naming the
    /// parameter; a name not held is not this check's.
    #[test]
    fn a_read_only_value_takes_only_itself() {
        let held = vec![
            ("a".to_owned(), ParameterValue::Double(f64::NAN)),
            (
                "b".to_owned(),
                ParameterValue::DoubleArray(vec![1.0, f64::NAN]),
            ),
            ("c".to_owned(), ParameterValue::String("sim".into())),
        ];
        let answer = |name: &str, v: ParameterValue| read_only_answer(&held, name, &v, "it");
        assert_eq!(answer("a", ParameterValue::Double(f64::NAN)), Some(Ok(())));
        let b = ParameterValue::DoubleArray(vec![1.0, f64::NAN]);
        assert_eq!(answer("b", b), Some(Ok(())));
        assert_eq!(
            answer("c", ParameterValue::String("sim".into())),
            Some(Ok(()))
        );
        let refused = answer("c", ParameterValue::String("serial".into()))
            .unwrap()
            .unwrap_err();
        assert!(refused.contains("`c` is read at start only") && refused.ends_with("restart it"));
        assert!(answer("a", ParameterValue::Double(1.0)).unwrap().is_err());
        assert_eq!(answer("d", ParameterValue::Double(1.0)), None);
    }
}
