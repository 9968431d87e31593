//! The cache's store over HTTP, as Bazel's remote cache speaks it: `GET` and `PUT` of
//! `URL/ac/KEY` and `URL/cas/SHA256` (bazel-remote, BuildBuddy, nginx with WebDAV `PUT`).
//! Credentials come from the environment and are never printed.

use super::cache::Store;
use std::time::Duration;

/// A remote cache at an `http://` (or, with the feature `https`, `https://`) URL.
pub struct HttpStore {
    base: String,
    auth: Option<String>,
    agent: ureq::Agent,
}

impl HttpStore {
    /// The cache at `url`, with `CUBEFORGE_CACHE_TOKEN` (a bearer token) or
    /// `CUBEFORGE_CACHE_USER` and `CUBEFORGE_CACHE_PASSWORD` (basic) from the environment.
    pub fn from_env(url: &str) -> std::result::Result<HttpStore, String> {
        let base = url.trim_end_matches('/').to_string();
        let rest = base
            .strip_prefix("http://")
            .or_else(|| base.strip_prefix("https://"))
            .filter(|r| !r.is_empty())
            .ok_or_else(|| format!("{url:?}: give the cache as an http:// or https:// URL"))?;
        if cfg!(not(feature = "https")) && base.starts_with("https://") {
            return Err(format!(
                "{url:?}: this cubeforge speaks http:// only; https:// needs it built with the \
                 cargo feature `https` (cargo install --locked --path . --features https)"
            ));
        }
        if rest
            .split('/')
            .next()
            .is_some_and(|host| host.contains('@'))
        {
            return Err(
                "the cache's URL holds credentials: give them in CUBEFORGE_CACHE_TOKEN, or \
                 CUBEFORGE_CACHE_USER and CUBEFORGE_CACHE_PASSWORD, where no log shows them"
                    .into(),
            );
        }
        let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        let auth = match (
            var("CUBEFORGE_CACHE_TOKEN"),
            var("CUBEFORGE_CACHE_USER"),
            var("CUBEFORGE_CACHE_PASSWORD"),
        ) {
            (Some(t), _, _) => Some(format!("Bearer {t}")),
            (None, Some(u), p) => {
                use base64::Engine;
                let pair = format!("{u}:{}", p.unwrap_or_default());
                Some(format!(
                    "Basic {}",
                    base64::engine::general_purpose::STANDARD.encode(pair)
                ))
            }
            _ => None,
        };
        let agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_connect(Some(Duration::from_secs(5)))
            .timeout_global(Some(Duration::from_secs(600)))
            .build()
            .into();
        Ok(HttpStore { base, auth, agent })
    }

    fn url(&self, path: &str) -> String {
        format!("{}/{path}", self.base)
    }
}

/// A status line for a warning (the body stays unread: it may echo headers).
fn status(code: ureq::http::StatusCode) -> String {
    format!("HTTP {code}")
}

impl Store for HttpStore {
    fn get(&self, path: &str, most: u64) -> std::result::Result<Option<Vec<u8>>, String> {
        let mut req = self.agent.get(self.url(path));
        if let Some(a) = &self.auth {
            req = req.header("Authorization", a);
        }
        let mut resp = req.call().map_err(|e| e.to_string())?;
        match resp.status().as_u16() {
            200 => {
                use std::io::Read;
                let mut bytes = Vec::new();
                let body = resp.body_mut().with_config().limit(u64::MAX).reader();
                body.take(most.saturating_add(1))
                    .read_to_end(&mut bytes)
                    .map(|_| Some(bytes))
                    .map_err(|e| e.to_string())
            }
            404 => Ok(None),
            _ => Err(status(resp.status())),
        }
    }

    fn put(&self, path: &str, bytes: &[u8]) -> std::result::Result<(), String> {
        let mut req = self.agent.put(self.url(path));
        if let Some(a) = &self.auth {
            req = req.header("Authorization", a);
        }
        let resp = req.send(bytes).map_err(|e| e.to_string())?;
        if resp.status().is_success() {
            Ok(())
        } else {
            Err(status(resp.status()))
        }
    }

    fn name(&self) -> String {
        self.base.clone()
    }

    fn has(&self, path: &str) -> std::result::Result<bool, String> {
        let mut req = self.agent.head(self.url(path));
        if let Some(a) = &self.auth {
            req = req.header("Authorization", a);
        }
        let resp = req.call().map_err(|e| e.to_string())?;
        match resp.status().as_u16() {
            200 => Ok(true),
            404 => Ok(false),
            _ => Err(status(resp.status())),
        }
    }
}
