// docs/cli.md's flag tables, walked out of the CLI11 app (see cli_reference.hpp).
#include "apps/cli_reference.hpp"

#include <CLI/CLI.hpp>

#include <cctype>
#include <functional>
#include <string>
#include <vector>

namespace rayline::cli {

namespace {

// A table cell: pipes escaped, so that a description such as "gmb | budge" stays in its cell.
std::string cell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string code(const std::string& text) { return text.empty() ? std::string() : "`" + cell(text) + "`"; }

// The units a kind of value accepts (cli_reference.hpp), or empty.
std::string units_of(const std::string& kind) {
  if (kind.find(kDuration) != std::string::npos) return "ns, us, ms, s, min, h (required)";
  if (kind == kSize) return "B, kB, MB, GB, TB, KiB, MiB, GiB, TiB (required)";
  if (kind == kCount) return "none, K, M, G (10^3, 10^6, 10^9)";
  return {};
}

// "-k, --horizon" (short names first, as in --help), or the positional's name in capitals.
std::string names_of(const CLI::Option& opt) {
  std::string names;
  for (const std::string& s : opt.get_snames()) names += (names.empty() ? "" : ", ") + code("-" + s);
  for (const std::string& l : opt.get_lnames()) names += (names.empty() ? "" : ", ") + code("--" + l);
  if (!names.empty()) return names;
  std::string positional = opt.get_name();
  for (char& c : positional) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return code(positional) + " (positional)";
}

// The option's row: flag names | value kind | units or allowed values | default | meaning.
std::string row(const CLI::Option& opt) {
  const std::string full = opt.get_type_name();  // KIND, then ":" and each check's description
  const std::size_t colon = full.find(':');
  const std::string kind = full.substr(0, colon);
  std::string allowed = colon == std::string::npos ? std::string() : full.substr(colon + 1);
  // CLI::Range describes itself as "INT in [1 - 64]" (INT for any integer): keep "[1 - 64]".
  if (const std::size_t in = allowed.find(" in ["); in != std::string::npos && allowed.find(' ') == in)
    allowed = allowed.substr(in + 4);
  std::string units = units_of(kind);
  if (!allowed.empty()) units += (units.empty() ? "" : "; ") + allowed;
  const bool flag = full.empty();  // a flag takes no value, so has no type name
  std::string meaning = opt.get_description();
  if (opt.get_group() != "Options") meaning = "*" + opt.get_group() + ":* " + meaning;
  return "| " + names_of(opt) + " | " + (flag ? std::string("flag") : code(kind)) + " | " + cell(units) + " | " +
         (flag ? std::string() : code(opt.get_default_str())) + " | " + cell(meaning) + " |\n";
}

// `app` and, below it, each of its subcommands in the order they were added.
void section(const CLI::App& app, const std::string& path, std::string& out) {
  out += "\n## `" + path + "`\n\n" + app.get_description() + "\n";
  const CLI::Option* help = app.get_help_ptr();
  const std::vector<const CLI::Option*> options = app.get_options(
      [help](const CLI::Option* o) { return o != help && !o->get_group().empty(); });
  const std::vector<const CLI::App*> subs = app.get_subcommands(std::function<bool(const CLI::App*)>{});
  if (!subs.empty()) {
    out += "\nSubcommands:";
    for (std::size_t i = 0; i < subs.size(); ++i) out += (i ? ", " : " ") + code(subs[i]->get_name());
    out += ".\n";
  }
  if (!options.empty()) {
    out += "\n| Flag | Value | Units / allowed | Default | Meaning |\n|---|---|---|---|---|\n";
    for (const CLI::Option* o : options) out += row(*o);
  }
  for (const CLI::App* sub : subs) section(*sub, path + " " + sub->get_name(), out);
}

}  // namespace

std::string cli_reference(const CLI::App& app) {
  std::string out;
  section(app, "rayline", out);
  return out;
}

}  // namespace rayline::cli
