//! The command line as Markdown tables, one per subcommand, for README.md's
//! "Command line" section. Made from the same clap definitions `--help` prints, so a
//! test can hold README to them (`tests/cli/cli.rs`): a flag added, renamed or dropped
//! fails it until the table is made again (`HOMCULL_BLESS=1 cargo test --test cli`).

use clap::CommandFactory;

use super::commands::Cli;

/// Every subcommand's flags: one `### homcull SUB` heading and table each, in
/// `--help` order.
pub fn flags_table() -> String {
    let cli = Cli::command();
    let mut out = String::new();
    for sub in cli.get_subcommands() {
        let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
        out.push_str(&format!(
            "#### `homcull {}`\n\n{}\n\n",
            sub.get_name(),
            one_line(&about)
        ));
        out.push_str("| flag | env | default | what |\n|---|---|---|---|\n");
        for arg in sub.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            if arg.is_hide_set() {
                continue;
            }
            let mut flag = format!("`--{long}`");
            if let Some(aliases) = arg.get_visible_aliases() {
                for a in aliases {
                    flag.push_str(&format!(" (`--{a}`)"));
                }
            }
            let env = arg
                .get_env()
                .map(|e| format!("`{}`", e.to_string_lossy()))
                .unwrap_or_default();
            let defaults: Vec<String> = arg
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into_owned())
                .collect();
            let default = if defaults.is_empty() {
                String::new()
            } else {
                format!("`{}`", defaults.join(","))
            };
            let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
            out.push_str(&format!(
                "| {flag} | {env} | {default} | {} |\n",
                one_line(&help)
            ));
        }
        out.push('\n');
    }
    out
}

/// Help text on one table line: whitespace collapsed, pipes escaped.
fn one_line(s: &str) -> String {
    s.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}
