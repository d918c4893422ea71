//! Building the configuration's TOML table: a user file merged over the embedded default key by
//! key, then `--set section.key=value` overrides (values read as TOML, unknown keys refused
//! with the known ones listed).

use super::{ConfigError, OPTIONAL_KEYS};

/// Deep merge: tables merge key by key, anything else is replaced.
pub(super) fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Applies one `section.key=value` override. The value is read as TOML (numbers, booleans,
/// arrays, quoted strings); anything that is not valid TOML is taken as a bare string.
pub(super) fn apply_set(table: &mut toml::Table, arg: &str) -> Result<(), ConfigError> {
    let err = |message: String| ConfigError::Set {
        arg: arg.into(),
        message,
    };
    let (path, raw) = arg
        .split_once('=')
        .ok_or_else(|| err("expected section.key=value".into()))?;
    let (section, key) = path
        .trim()
        .split_once('.')
        .ok_or_else(|| err("expected section.key=value, e.g. domain.nx=500".into()))?;
    let raw = raw.trim();
    let value = match format!("v = {raw}").parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_) => toml::Value::String(raw.into()),
    };
    let sections: Vec<String> = table.keys().cloned().collect();
    let Some(toml::Value::Table(sec)) = table.get_mut(section) else {
        return Err(err(format!(
            "unknown section `{section}`; sections are: {}",
            sections.join(", ")
        )));
    };
    let optional = OPTIONAL_KEYS.contains(&(section, key));
    if !sec.contains_key(key) && !optional {
        let mut known: Vec<&str> = sec.keys().map(String::as_str).collect();
        known.extend(OPTIONAL_KEYS.iter().filter(|o| o.0 == section).map(|o| o.1));
        return Err(err(format!(
            "unknown key `{key}` in [{section}]; known keys: {}",
            known.join(", ")
        )));
    }
    sec.insert(key.into(), value);
    Ok(())
}
