//! ROS 2 names: namespaces and frame or joint names (the subset of the ROS 2 naming rules the
//! service uses: ASCII letters, digits and single `_`, not starting with a digit).

/// Longest namespace, characters.
pub const MAX_NAMESPACE_LEN: usize = 100;

/// Whether `s` is one name segment: a letter or `_` first, then letters, digits and `_`, with
/// no `__` (reserved by ROS 2).
pub fn is_name_segment(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !s.contains("__")
}

/// Checks a namespace: `/`, or `/`-separated [`is_name_segment`]s after a leading `/`, no
/// trailing `/`, at most [`MAX_NAMESPACE_LEN`] characters. The error says which rule it breaks.
pub fn check_namespace(ns: &str) -> Result<(), String> {
    if ns.len() > MAX_NAMESPACE_LEN {
        return Err(format!(
            "{} characters, at most {MAX_NAMESPACE_LEN}",
            ns.len()
        ));
    }
    if ns == "/" {
        return Ok(());
    }
    let Some(rest) = ns.strip_prefix('/') else {
        return Err(format!("`{ns}` must start with `/`"));
    };
    if rest.split('/').all(is_name_segment) {
        Ok(())
    } else {
        Err(format!(
            "`{ns}`: segments are letters, digits and single `_`, not starting with a digit, \
             separated by single `/`, no trailing `/`"
        ))
    }
}

/// `name` in namespace `ns` (`/lwr` + `payload` = `/lwr/payload`; `/` + `x` = `/x`).
pub fn in_namespace(ns: &str, name: &str) -> String {
    format!("{}/{name}", ns.trim_end_matches('/'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces_follow_the_ros_rules() {
        for ok in ["/", "/lwr", "/lab_1/arm"] {
            assert!(check_namespace(ok).is_ok(), "{ok}");
        }
        for bad in ["lwr", "/lwr/", "/1arm", "/a__b", "/a//b", "/a-b"] {
            assert!(check_namespace(bad).is_err(), "{bad}");
        }
        assert!(check_namespace(&format!("/{}", "a".repeat(100))).is_err());
        assert_eq!(in_namespace("/lwr", "payload"), "/lwr/payload");
        assert_eq!(in_namespace("/", "x"), "/x");
    }
}
