//! Every citation of the project's notes resolves: `physics.md §N.M` to a heading of
//! `docs/physics.md`, `validation.md §N` to a heading of `docs/validation.md`, and `docs/<name>.md`
//! to a file that exists.
//!
//! # Scanned files
//!
//! Every `.rs`, `.toml` and `.md` file of the repository, except under `target/`, `.git/`,
//! `shared/`, `.venv*/` and `.qc-venv/`.
//!
//! # Accepted citation grammar
//!
//! ```text
//! citation  = document [ "`" ] [ gap section { more } ]
//! document  = [ "docs/" ] ( "physics.md" | "validation.md" )
//! section   = "§" id
//! id        = digits { "." digits } [ letter | "(" letter ")" ]     "9(b)" is read as "9b"
//! more      = [ gap "(" note ")" ] gap* separator gap* section
//! separator = "," | ";" | "/" | "and"
//! gap       = spaces, or a line break followed by a comment leader (`//`, `///`, `//!`, `#`)
//! ```
//!
//! So `physics.md §2.4, §1.5`, `physics.md §2.1/§2.2`, `physics.md §1.4 (P.838-3), §1.5 (P.676)`,
//! `` `physics.md` §5.3 `` and a `physics.md` at the end of one comment line with its `§2.4` at the
//! start of the next all cite docs/physics.md. A `§` that is not chained to a document this way
//! (a bare `(§1.3)` further on) is not a citation of these notes and is not checked; write the
//! document name before it. A document named with any other directory (e.g. the reference notes
//! beside the checkout) is reported: the repository's copy lives in `docs/`.
//!
//! # Resolution
//!
//! A section id resolves when exactly one Markdown heading (outside code fences) of the cited file
//! starts with the id followed by a space, a `.` that is not followed by a digit, `:` or the end:
//! `§1` → `## 1. Radar`, `§1.1` → `### 1.1 Range equation …`, `§9c` → `### 9c …` (and `§9` does
//! not match `9c`, nor `§1` match `1.1`).

use std::path::{Path, PathBuf};

/// The two notes whose sections are cited.
const NOTES: [&str; 2] = ["physics.md", "validation.md"];

/// One citation found in a source file.
#[derive(Debug, Clone, PartialEq)]
struct Citation {
    /// 1-based line of the document name.
    line: usize,
    /// The document as written (`physics.md`, `docs/consistency.md`, or with another directory).
    document: String,
    /// The cited section ids (empty for a bare reference).
    sections: Vec<String>,
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/')
}

/// Skips spaces and tabs; with `newlines`, also line breaks followed by a comment leader.
fn skip_gap(s: &[char], mut i: usize, newlines: bool) -> usize {
    loop {
        while i < s.len() && (s[i] == ' ' || s[i] == '\t') {
            i += 1;
        }
        if newlines && i < s.len() && (s[i] == '\n' || s[i] == '\r') {
            while i < s.len() && s[i].is_whitespace() {
                i += 1;
            }
            while i < s.len() && (s[i] == '/' || s[i] == '!' || s[i] == '#') {
                i += 1;
            }
            continue;
        }
        return i;
    }
}

/// Parses `§id` at `i`; returns the normalised id and the index after it.
fn parse_section(s: &[char], i: usize) -> Option<(String, usize)> {
    if s.get(i) != Some(&'§') {
        return None;
    }
    let mut j = i + 1;
    let mut id = String::new();
    loop {
        let start = j;
        while j < s.len() && s[j].is_ascii_digit() {
            id.push(s[j]);
            j += 1;
        }
        if j == start {
            return None; // "§" without digits, or "1." followed by a non-digit (handled below)
        }
        if j + 1 < s.len() && s[j] == '.' && s[j + 1].is_ascii_digit() {
            id.push('.');
            j += 1;
            continue;
        }
        break;
    }
    let alnum = |k: usize| s.get(k).is_some_and(|c| c.is_alphanumeric());
    if s.get(j).is_some_and(|c| c.is_ascii_lowercase()) && !alnum(j + 1) {
        id.push(s[j]);
        j += 1;
    } else if s.get(j) == Some(&'(')
        && s.get(j + 1).is_some_and(|c| c.is_ascii_lowercase())
        && s.get(j + 2) == Some(&')')
    {
        id.push(s[j + 1]);
        j += 3;
    }
    Some((id, j))
}

/// Parses the chain `more*` after a first section ending at `i`.
fn parse_more(s: &[char], mut i: usize, out: &mut Vec<String>) {
    loop {
        let mut j = skip_gap(s, i, true);
        // An optional parenthesised note on one line: "§1.4 (P.838-3), §1.5".
        if s.get(j) == Some(&'(') {
            let mut k = j + 1;
            while k < s.len() && !matches!(s[k], '(' | ')' | '\n') {
                k += 1;
            }
            if s.get(k) != Some(&')') {
                return;
            }
            j = skip_gap(s, k + 1, true);
        }
        let after_sep = match s.get(j) {
            Some(',' | ';' | '/') => j + 1,
            Some('a') if s.get(j + 1) == Some(&'n') && s.get(j + 2) == Some(&'d') => j + 3,
            _ => return,
        };
        let k = skip_gap(s, after_sep, true);
        match parse_section(s, k) {
            Some((id, end)) => {
                out.push(id);
                i = end;
            }
            None => return,
        }
    }
}

/// Every citation of a `*.md` document in `text` that is one of [`NOTES`] or lies under `docs/`.
fn scan(text: &str) -> Vec<Citation> {
    let s: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut line = 1;
    let mut i = 0;
    while i + 3 <= s.len() {
        if s[i] == '\n' {
            line += 1;
        }
        let is_md = s[i] == '.'
            && s[i + 1] == 'm'
            && s[i + 2] == 'd'
            && !s
                .get(i + 3)
                .is_some_and(|c| c.is_alphanumeric() || *c == '_');
        if !is_md {
            i += 1;
            continue;
        }
        let mut b = i;
        while b > 0 && is_path_char(s[b - 1]) {
            b -= 1;
        }
        let document: String = s[b..i + 3].iter().collect();
        let document = document.trim_start_matches("./").to_owned();
        let name = document.rsplit('/').next().unwrap_or("");
        let end = i + 3;
        i = end;
        if name == ".md" || name.is_empty() {
            continue;
        }
        let is_note = NOTES.contains(&name);
        if !is_note && !document.starts_with("docs/") {
            continue;
        }
        let mut sections = Vec::new();
        if is_note {
            let mut j = end;
            if s.get(j) == Some(&'`') {
                j += 1;
            }
            let j = skip_gap(&s, j, true);
            if let Some((id, k)) = parse_section(&s, j) {
                sections.push(id);
                parse_more(&s, k, &mut sections);
            }
        }
        out.push(Citation {
            line,
            document,
            sections,
        });
    }
    out
}

/// The heading texts of a Markdown file (without the `#`s), outside code fences.
fn headings(markdown: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for l in markdown.lines() {
        if l.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced && l.starts_with('#') {
            out.push(l.trim_start_matches('#').trim().to_owned());
        }
    }
    out
}

/// Whether heading text `h` is the heading of section `id`.
fn heading_is(h: &str, id: &str) -> bool {
    let Some(rest) = h.strip_prefix(id) else {
        return false;
    };
    let mut c = rest.chars();
    match c.next() {
        None | Some(' ' | ':') => true,
        Some('.') => !c.next().is_some_and(|d| d.is_ascii_digit()),
        _ => false,
    }
}

/// `a/b/../c` → `a/c`, `./` dropped (a path relative to the repository root).
fn normalise(path: &str) -> String {
    let mut parts: Vec<&str> = Vec::new();
    for p in path.split('/') {
        match p {
            "" | "." => {}
            ".." => {
                parts.pop();
            }
            p => parts.push(p),
        }
    }
    parts.join("/")
}

/// The problems of the citations of one file (`source` is the path shown in the messages);
/// `docs` is the repository's `docs/` directory.
fn unresolved(source: &str, text: &str, docs: &Path) -> (usize, Vec<String>) {
    let mut checked = 0;
    let mut problems = Vec::new();
    for c in scan(text) {
        let name = c.document.rsplit('/').next().unwrap_or("");
        let at = format!("{source}:{}", c.line);
        if NOTES.contains(&name) {
            let dir = &c.document[..c.document.len() - name.len()];
            // A relative Markdown link (one folder up from a page in a docs subfolder) resolves
            // against the citing file's folder.
            let relative_to_docs = (dir.starts_with("../") || dir.starts_with("./"))
                && normalise(&format!(
                    "{}/{}",
                    source.rsplit_once('/').map_or("", |(d, _)| d),
                    c.document
                )) == format!("docs/{name}");
            if !(dir.is_empty() || dir == "docs/" || dir.ends_with("/docs/") || relative_to_docs) {
                problems.push(format!(
                    "{at}: `{}` is not in the repository; cite docs/{name}",
                    c.document
                ));
                continue;
            }
            let Ok(md) = std::fs::read_to_string(docs.join(name)) else {
                problems.push(format!("{at}: docs/{name} does not exist"));
                continue;
            };
            let hs = headings(&md);
            for id in &c.sections {
                checked += 1;
                let n = hs.iter().filter(|h| heading_is(h, id)).count();
                if n != 1 {
                    problems.push(format!(
                        "{at}: {name} §{id} matches {n} headings of docs/{name} (needs exactly one)"
                    ));
                }
            }
        } else {
            checked += 1;
            let rel = c.document.trim_start_matches("docs/");
            if !docs.join(rel).is_file() {
                problems.push(format!("{at}: {} does not exist", c.document));
            }
        }
    }
    (checked, problems)
}

fn skipped(name: &str) -> bool {
    matches!(name, "target" | ".git" | "shared" | ".qc-venv") || name.starts_with(".venv")
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_dir() {
            if !skipped(&name) {
                walk(&p, out);
            }
        } else if ft.is_file()
            && matches!(
                p.extension().and_then(|x| x.to_str()),
                Some("rs" | "toml" | "md")
            )
        {
            out.push(p);
        }
    }
}

#[test]
fn the_checker_reports_what_does_not_resolve() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let docs = root.join("docs");
    // Built at run time so that the repository scan does not see them as citations.
    let s = '§';
    let fabricated = format!("// See physics.md {s}9.9 for the sea state.\n");
    let (n, p) = unresolved("fabricated.rs", &fabricated, &docs);
    assert_eq!(n, 1);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].contains("9.9") && p[0].contains("0 headings"), "{p:?}");
    // A later section of a list is checked too, across a comment line break.
    let listed = format!("//! (physics.md {s}1.1, {s}1.6,\n//! {s}7.77).\n");
    let (n, p) = unresolved("listed.rs", &listed, &docs);
    assert_eq!((n, p.len()), (3, 1), "{p:?}");
    assert!(p[0].contains("§7.77"), "{p:?}");
    // A missing docs/ file, and a note cited outside docs/.
    let missing = format!("see docs/{}.md\n", "no-such-note");
    assert_eq!(unresolved("m.md", &missing, &docs).1.len(), 1);
    let outside = format!("`shared/reference/{}` {s}5\n", NOTES[0]);
    assert_eq!(unresolved("o.rs", &outside, &docs).1.len(), 1);
    // A relative link resolves against the citing file's folder: docs/models/ → docs/, but the
    // same link from src/ points outside docs/.
    let relative = format!("[v](../{})\n", NOTES[1]);
    let page = format!("docs/models/m.{}", "md");
    assert!(unresolved(&page, &relative, &docs).1.is_empty());
    assert_eq!(unresolved("src/m.rs", &relative, &docs).1.len(), 1);
    // `§1` must not resolve to a `1.1` heading, nor `§9` to `9c`.
    assert!(heading_is("1. Radar", "1") && !heading_is("1.1 Range", "1"));
    assert!(heading_is("9c Rain", "9c") && !heading_is("9c Rain", "9"));
}

#[test]
fn the_grammar_reads_the_forms_the_code_uses() {
    let s = '§';
    let ids = |t: &str| -> Vec<Vec<String>> { scan(t).into_iter().map(|c| c.sections).collect() };
    let v = |x: &[&str]| x.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert_eq!(
        ids(&format!("(physics.md {s}2.4, {s}1.5)")),
        [v(&["2.4", "1.5"])]
    );
    assert_eq!(
        ids(&format!("physics.md {s}2.1/{s}2.2 ex")),
        [v(&["2.1", "2.2"])]
    );
    assert_eq!(
        ids(&format!(
            "physics.md {s}1.4 (P.838-3), {s}1.5 (P.676, P.840), {s}2.4 (fog),\n//! {s}2.5 (rain)"
        )),
        [v(&["1.4", "1.5", "2.4", "2.5"])]
    );
    assert_eq!(ids(&format!("`physics.md` {s}5.3).")), [v(&["5.3"])]);
    assert_eq!(
        ids(&format!("physics.md\n    // {s}2.4); solve")),
        [v(&["2.4"])]
    );
    assert_eq!(ids(&format!("validation.md {s}9c), and")), [v(&["9c"])]);
    assert_eq!(ids(&format!("validation.md {s}9(b)); V")), [v(&["9b"])]);
    assert_eq!(ids(&format!("validation.md {s}9.")), [v(&["9"])]);
    assert_eq!(
        ids(&format!("physics.md {s}3.1); x (y, {s}3.3)")),
        [v(&["3.1"])]
    );
    assert_eq!(ids(&format!("physics.md {s}2.6; Hebert")), [v(&["2.6"])]);
    assert_eq!(ids("Checked against physics.md: 5.9"), [v(&[])]);
}

#[test]
fn every_citation_of_the_notes_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let docs = root.join("docs");
    let mut files = Vec::new();
    walk(root, &mut files);
    files.sort();
    let (mut checked, mut sections, mut problems) = (0, 0, Vec::new());
    for f in &files {
        let Ok(text) = std::fs::read_to_string(f) else {
            continue;
        };
        let rel = f.strip_prefix(root).unwrap_or(f).display().to_string();
        sections += scan(&text).iter().map(|c| c.sections.len()).sum::<usize>();
        let (n, p) = unresolved(&rel, &text, &docs);
        checked += n;
        problems.extend(p);
    }
    println!(
        "{} files scanned; {checked} citations checked ({sections} section citations of \
         docs/physics.md and docs/validation.md); {} unresolved",
        files.len(),
        problems.len()
    );
    assert!(
        sections > 100,
        "only {sections} section citations found: the scanner is broken"
    );
    assert!(
        problems.is_empty(),
        "unresolved citations:\n{}",
        problems.join("\n")
    );
}
