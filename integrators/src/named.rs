//! Choices made by name (a sampler, a light selection): a table of names and values, read
//! both ways.

/// The name of `value` in `all` (the first name if it is missing, which a complete table
/// never lets happen).
pub fn name_of<T: PartialEq + Copy>(all: &[(&'static str, T)], value: T) -> &'static str {
    all.iter()
        .find(|(_, v)| *v == value)
        .map_or(all[0].0, |(n, _)| n)
}

/// The value named `name` in `all`; else an error naming the `what` (singular, plural) and
/// every name there is.
pub fn parse_named<T: Copy>(
    all: &[(&'static str, T)],
    name: &str,
    (one, many): (&str, &str),
) -> Result<T, String> {
    all.iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<&str> = all.iter().map(|(n, _)| *n).collect();
            format!("no {one} `{name}`; {many}: {}", names.join(", "))
        })
}
