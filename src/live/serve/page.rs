//! The page `raylab serve` shows: one self-contained HTML file (inline CSS and script, no
//! network but its own server). It long-polls `/state`, swaps the image when a new one
//! arrives, shows the render statistics and the load error, and offers a menu of the
//! integrators and their parameters (built from `/integrators`) that posts to `/settings`.
//!
//! Opening it with `#selftest=NAME` makes it test itself: once the first image is shown it
//! switches the menu to integrator NAME, waits for an image rendered by NAME to arrive and
//! load, and puts the verdict in the title (`selftest: ok` or `selftest: FAIL: why`) and in
//! `#verdict`; the headless-Chromium test reads it. It then stops polling.

//!
//! The page is three real files beside this module (`page.html`, `page.css`, `page.js`), put
//! together into one self-contained page when raylab is built.

use std::sync::OnceLock;

/// The page: the HTML with its style and script inlined where it marks them.
pub fn page() -> &'static str {
    static PAGE: OnceLock<String> = OnceLock::new();
    PAGE.get_or_init(|| {
        include_str!("page.html")
            .replace("/* page.css */", include_str!("page.css"))
            .replace("/* page.js */", include_str!("page.js"))
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_page_inlines_its_style_and_script() {
        let page = super::page();
        assert!(page.contains("<style>") && page.contains("font: 14px/1.4 system-ui"));
        assert!(page.contains("<script>") && page.contains("selftest"));
        assert!(!page.contains("/* page.css */") && !page.contains("/* page.js */"));
    }
}
