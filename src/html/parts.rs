//! What each kind of run adds to the page: its key facts, its warnings and its diagnostics.

use super::warnings::Warnings;

/// A run kind's contribution to the page (HTML already escaped).
#[derive(Debug, Default)]
pub struct Parts {
    /// Key facts for the page's header: term and HTML value.
    pub facts: Vec<(&'static str, String)>,
    pub warnings: Warnings,
    /// The diagnostics section's body.
    pub diagnostics: String,
}
