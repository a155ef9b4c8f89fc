#!/usr/bin/env python3
"""The reference docs describe every option and every bank key the code accepts.

Usage: docs_cover_cli_and_bank_test.py SOURCE_DIR SKIDIMM_EXECUTABLE

docs/cli.md: for every subcommand `skidimm --help` lists, every long option
`skidimm <command> --help` prints must appear
  * in the command's lines of the synopsis (the first code block), and
  * in the command's own section (## `skidimm <command>`) or in a section
    that belongs to no command (## Logs, ## Plugin search path), where
    options shared by several commands are described once.

docs/bank-format.md: every key the bank loader accepts, taken from its own
lists (the check_keys(...) calls that reject unknown keys, in
core/src/bank_loader.cc and core/src/yaml_fields.h), must be described:
  * a top-level key in the "Top-level keys" section, as `key`;
  * a key of a named block (check_keys(node, {...}, "decision")) in that
    block's section (## `decision`), as `key` or `key:`;
  * a key of a block whose name is computed (modes[i], a covariance) as
    `key` or `key:` anywhere in the page.
A check_keys call whose list is not a literal {...} is an error here, so
that a new kind of list cannot slip past the test unread.

Each missing item is named; the exit status is 1 if any is missing.
"""
import re
import subprocess
import sys
from pathlib import Path


def sections(markdown):
    """{heading text: body} for the level-2 sections (### stay in their ## section)."""
    out = {}
    current = None
    for line in markdown.splitlines():
        match = re.match(r"^## (.*)$", line)
        if match:
            current = match.group(1).strip()
            out[current] = ""
        elif current is not None:
            out[current] += line + "\n"
    return out


def mentions_option(text, option):
    # --lag must not be satisfied by --lagged, nor --output by --output-bank.
    return re.search(re.escape(option) + r"(?![A-Za-z0-9-])", text) is not None


def help_text(skidimm, *args):
    run = subprocess.run([skidimm, *args, "--help"], capture_output=True, text=True, timeout=30)
    if run.returncode != 0:
        sys.exit(f"'{skidimm} {' '.join(args)} --help' exited {run.returncode}: {run.stderr}")
    return run.stdout


def check_cli(source, skidimm):
    problems = []
    doc_path = source / "docs" / "cli.md"
    doc = doc_path.read_text()
    synopsis_match = re.search(r"```\n(.*?)```", doc, re.S)
    synopsis = synopsis_match.group(1) if synopsis_match else ""
    by_section = sections(doc)
    general = "".join(body for title, body in by_section.items() if not title.startswith("`skidimm "))

    top = help_text(skidimm)
    listing = top.split("Subcommands:", 1)
    if len(listing) != 2:
        sys.exit("`skidimm --help` lists no subcommands")
    commands = re.findall(r"^  ([a-z][a-z0-9-]*)\s", listing[1], re.M)
    if not commands:
        sys.exit("no subcommand found in `skidimm --help`")

    for command in commands:
        # The command's synopsis: its line(s) starting `skidimm <command> `, with their indented continuations.
        lines = []
        taking = False
        for line in synopsis.splitlines():
            if line.startswith("skidimm "):
                taking = re.match(r"skidimm " + re.escape(command) + r"\s", line + " ") is not None
            if taking:
                lines.append(line)
        command_synopsis = "\n".join(lines)
        if not command_synopsis:
            problems.append(f"docs/cli.md: the synopsis has no line for `skidimm {command}`")
        section = by_section.get(f"`skidimm {command}`")
        if section is None:
            problems.append(f"docs/cli.md: no section '## `skidimm {command}`'")
            section = ""
        options = sorted(set(re.findall(r"(?<![A-Za-z0-9-])(--[a-z][a-z0-9-]*)", help_text(skidimm, command))))
        for option in options:
            if option == "--help":
                continue
            if command_synopsis and not mentions_option(command_synopsis, option):
                problems.append(f"docs/cli.md: `skidimm {command} {option}` is missing from the synopsis")
            if not mentions_option(section, option) and not mentions_option(general, option):
                problems.append(
                    f"docs/cli.md: `skidimm {command} {option}` is described neither in "
                    f"'## `skidimm {command}`' nor in a section shared by the commands")
    return problems


def loader_key_lists(source):
    """[(file, line, level or None, [keys])] from every check_keys(...) call of the bank loader."""
    lists = []
    for name in ("core/src/bank_loader.cc", "core/src/yaml_fields.h"):
        text = (source / name).read_text()
        for call in re.finditer(r"\bcheck_keys\(", text):
            line = text.count("\n", 0, call.start()) + 1
            rest = text[call.end():]
            if rest.startswith("const YAML::Node&"):  # the definition, not a call
                continue
            match = re.match(r"\s*[^,{}()]+(?:\([^()]*\))?\s*,\s*\{([^{}]*)\}\s*,\s*(\"[^\"]*\"|[A-Za-z_][A-Za-z0-9_]*)\s*\)",
                             rest, re.S)
            if not match:
                lists.append((name, line, None, None))
                continue
            keys = re.findall(r"\"([^\"]+)\"", match.group(1))
            level = match.group(2)
            level = level[1:-1] if level.startswith('"') else None
            lists.append((name, line, level, keys))
    return lists


def check_bank(source):
    problems = []
    doc = (source / "docs" / "bank-format.md").read_text()
    by_section = sections(doc)
    lists = loader_key_lists(source)
    if not any(level == "" for _, _, level, _ in lists):
        problems.append("core/src/bank_loader.cc: found no check_keys(root, {...}, \"\") list of top-level keys")

    def described(text, key):
        return re.search(r"`" + re.escape(key) + r"`|(?<![A-Za-z0-9_])" + re.escape(key) + r":", text) is not None

    for name, line, level, keys in lists:
        if keys is None:
            problems.append(f"{name}:{line}: a check_keys(...) call whose key list this test cannot read "
                            "(give it a literal {\"key\", ...} list, or teach tests/docs/ to read it)")
            continue
        if level == "":
            where, text = "the 'Top-level keys' section", by_section.get("Top-level keys", "")
            for key in keys:
                if f"`{key}`" not in text:
                    problems.append(f"docs/bank-format.md: top-level key `{key}` ({name}:{line}) is not in {where}")
            continue
        if level is None:
            where, text = "the page", doc
        else:
            where = f"'## `{level}`'"
            text = by_section.get(f"`{level}`")
            if text is None:
                problems.append(f"docs/bank-format.md: no section '## `{level}`' for the keys {keys} ({name}:{line})")
                continue
        for key in keys:
            if not described(text, key):
                label = f"{level}.{key}" if level else key
                problems.append(f"docs/bank-format.md: key `{label}` ({name}:{line}) is not described in {where}")
    return problems


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    source, skidimm = Path(sys.argv[1]), sys.argv[2]
    problems = check_cli(source, skidimm) + check_bank(source)
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} item(s) the code accepts are not documented")
        return 1
    print("every option of every command and every bank key is documented")
    return 0


if __name__ == "__main__":
    sys.exit(main())
