//! Just enough XML for the VTK files this crate writes and reads back:
//! attribute escaping and a flat scan for elements by name.

/// An element found by [`elements_named`]: its attributes and the raw text up
/// to its closing tag (empty for `<name ... />`).
#[derive(Debug)]
pub(crate) struct Element<'t> {
    pub(crate) attributes: Vec<(String, String)>,
    pub(crate) text: &'t str,
}

impl Element<'_> {
    /// The unescaped value of attribute `name`, if present.
    pub(crate) fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.as_str())
    }
}

/// Escapes `text` for a double-quoted attribute value.
pub(crate) fn escape(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for character in text.chars() {
        match character {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            '\'' => escaped.push_str("&apos;"),
            other => escaped.push(other),
        }
    }
    escaped
}

/// Reverses [`escape`]; other entity references are an error.
fn unescape(text: &str) -> Result<String, String> {
    let mut plain = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(ampersand) = rest.find('&') {
        plain.push_str(&rest[..ampersand]);
        let semicolon = rest[ampersand..]
            .find(';')
            .ok_or_else(|| format!("unterminated entity in `{text}`"))?;
        plain.push(match &rest[ampersand + 1..ampersand + semicolon] {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            other => return Err(format!("unknown entity `&{other};`")),
        });
        rest = &rest[ampersand + semicolon + 1..];
    }
    plain.push_str(rest);
    Ok(plain)
}

/// Every element called `name` in `document`, in order. Elements of the same
/// name must not nest, which holds for the VTK files handled here.
pub(crate) fn elements_named<'t>(
    document: &'t str,
    name: &str,
) -> Result<Vec<Element<'t>>, String> {
    let mut elements = Vec::new();
    let mut rest = document;
    while let Some(start) = find_start_tag(rest, name) {
        let after_name = &rest[start + 1 + name.len()..];
        let tag_end = after_name
            .find('>')
            .ok_or_else(|| format!("unterminated <{name}> tag"))?;
        let tag_body = &after_name[..tag_end];
        let after_tag = &after_name[tag_end + 1..];
        let (attribute_text, self_closing) = match tag_body.strip_suffix('/') {
            Some(body) => (body, true),
            None => (tag_body, false),
        };
        let attributes = parse_attributes(attribute_text)?;
        let (text, remaining) = if self_closing {
            ("", after_tag)
        } else {
            let closing = format!("</{name}>");
            let end = after_tag
                .find(&closing)
                .ok_or_else(|| format!("missing {closing}"))?;
            (&after_tag[..end], &after_tag[end + closing.len()..])
        };
        elements.push(Element { attributes, text });
        rest = remaining;
    }
    Ok(elements)
}

/// Byte offset of the next `<name` that is a whole tag name.
fn find_start_tag(text: &str, name: &str) -> Option<usize> {
    let opening = format!("<{name}");
    text.match_indices(&opening)
        .map(|(offset, _)| offset)
        .find(|&offset| {
            text[offset + opening.len()..]
                .chars()
                .next()
                .is_some_and(|next| next.is_whitespace() || next == '/' || next == '>')
        })
}

/// Parses `key="value"` pairs (single or double quotes) separated by whitespace.
fn parse_attributes(text: &str) -> Result<Vec<(String, String)>, String> {
    let mut attributes = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        let equals = rest
            .find('=')
            .ok_or_else(|| format!("attribute without value in `{text}`"))?;
        let key = rest[..equals].trim();
        let after_equals = rest[equals + 1..].trim_start();
        let quote = after_equals
            .chars()
            .next()
            .filter(|&quote| quote == '"' || quote == '\'')
            .ok_or_else(|| format!("unquoted value for `{key}`"))?;
        let value_end = after_equals[1..]
            .find(quote)
            .ok_or_else(|| format!("unterminated value for `{key}`"))?;
        attributes.push((key.to_string(), unescape(&after_equals[1..1 + value_end])?));
        rest = after_equals[value_end + 2..].trim_start();
    }
    Ok(attributes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaped_text_unescapes_to_the_original() {
        let original = r#"a&b<c>"d"'e'"#;
        assert_eq!(unescape(&escape(original)).unwrap(), original);
    }

    #[test]
    fn finds_elements_with_attributes_and_text() {
        let document = r#"<Root><Item a="1" b='x &amp; y'/><Items n="2">body</Items><Item a="3"></Item></Root>"#;
        let items = elements_named(document, "Item").unwrap();
        assert_eq!(items.len(), 2);
        assert_eq!(items[0].attribute("b"), Some("x & y"));
        assert_eq!(items[0].text, "");
        assert_eq!(items[1].attribute("a"), Some("3"));
        let lists = elements_named(document, "Items").unwrap();
        assert_eq!(lists[0].text, "body");
    }

    #[test]
    fn malformed_attributes_are_errors() {
        assert!(elements_named("<A b=c/>", "A").is_err());
        assert!(elements_named("<A b=\"c/>", "A").is_err());
    }
}
