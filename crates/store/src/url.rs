//! Database URLs fit to print: [`redacted`].

/// A database URL fit to print or log: the password of its user (`user:PASSWORD@`) and
/// the value of every query parameter whose name holds `password` are replaced by `***`.
/// A URL without them (a SQLite path) is returned as it is.
pub fn redacted(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_string();
    };
    let (authority, tail) = rest.split_at(rest.find(['/', '?', '#']).unwrap_or(rest.len()));
    let authority = match authority.rsplit_once('@') {
        Some((userinfo, host)) => match userinfo.split_once(':') {
            Some((user, _)) => format!("{user}:***@{host}"),
            None => authority.to_string(),
        },
        None => authority.to_string(),
    };
    let tail = match tail.split_once('?') {
        Some((path, query)) => {
            let params: Vec<String> = query
                .split('&')
                .map(|p| match p.split_once('=') {
                    Some((k, _)) if k.to_ascii_lowercase().contains("password") => {
                        format!("{k}=***")
                    }
                    _ => p.to_string(),
                })
                .collect();
            format!("{path}?{}", params.join("&"))
        }
        None => tail.to_string(),
    };
    format!("{scheme}://{authority}{tail}")
}

#[cfg(test)]
mod url_tests {
    #[test]
    fn passwords_never_print() {
        for (url, shown) in [
            (
                "postgres://mtcal:S3cr:et@db.example:5432/mtcal",
                "postgres://mtcal:***@db.example:5432/mtcal",
            ),
            (
                "postgresql://u:p%40ss@[::1]/db?sslmode=require&password=x&sslpassword=y",
                "postgresql://u:***@[::1]/db?sslmode=require&password=***&sslpassword=***",
            ),
            ("postgres://mtcal@db/mtcal", "postgres://mtcal@db/mtcal"),
            ("mysql://root:hunter2@h", "mysql://root:***@h"),
            ("/var/lib/mtcal/mtcal.sqlite", "/var/lib/mtcal/mtcal.sqlite"),
            ("sqlite://data/m.sqlite", "sqlite://data/m.sqlite"),
        ] {
            assert_eq!(super::redacted(url), shown);
        }
    }
}
