#include "mrd/profile/dbc.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "file_text.hpp"

namespace mrd::profile {
namespace {

constexpr std::size_t kMaxDbcBytes = 4u << 20;
constexpr std::uint32_t kExtendedFlag = 0x80000000U;

// A cursor over one statement (it may span lines: comments with line breaks).
class Scanner {
 public:
  Scanner(std::string_view s, int line) : s_(s), line_(line) {}

  void SkipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }
  bool AtEnd() {
    SkipSpace();
    return pos_ >= s_.size();
  }
  bool Eat(char c) {
    SkipSpace();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  // A C identifier.
  bool Ident(std::string* out) {
    SkipSpace();
    const std::size_t b = pos_;
    while (pos_ < s_.size() &&
           (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) {
      ++pos_;
    }
    if (pos_ == b || std::isdigit(static_cast<unsigned char>(s_[b]))) {
      pos_ = b;
      return false;
    }
    out->assign(s_.substr(b, pos_ - b));
    return true;
  }
  // A number token (decimal, sign, point, exponent), converted with strtod.
  bool Number(double* out) {
    SkipSpace();
    const std::size_t b = pos_;
    while (pos_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[pos_])) ||
                                std::strchr("+-.eE", s_[pos_]) != nullptr)) {
      ++pos_;
    }
    if (pos_ == b) return false;
    const std::string tok(s_.substr(b, pos_ - b));
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(tok.c_str(), &end);
    if (end != tok.c_str() + tok.size() || errno == ERANGE || !std::isfinite(v)) {
      pos_ = b;
      return false;
    }
    *out = v;
    return true;
  }
  bool Unsigned(std::uint64_t limit, std::uint64_t* out) {
    SkipSpace();
    const std::size_t b = pos_;
    std::uint64_t v = 0;
    while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) {
      const std::uint64_t d = static_cast<std::uint64_t>(s_[pos_] - '0');
      if (v > (limit - d) / 10) {
        pos_ = b;
        return false;
      }
      v = v * 10 + d;
      ++pos_;
    }
    if (pos_ == b) return false;
    *out = v;
    return true;
  }
  // A double-quoted string (no escapes in DBC); its content.
  bool Quoted(std::string* out) {
    SkipSpace();
    if (pos_ >= s_.size() || s_[pos_] != '"') return false;
    const std::size_t b = ++pos_;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= s_.size()) return false;
    out->assign(s_.substr(b, pos_ - b));
    ++pos_;
    return true;
  }
  int line() const { return line_; }

 private:
  std::string_view s_;
  std::size_t pos_ = 0;
  int line_;
};

std::string Where(const std::string& path, int line) {
  return path + ":" + std::to_string(line) + ": ";
}

// Keywords whose statements end with ';' (and may span lines).
bool SemicolonStatement(std::string_view kw) {
  static constexpr std::string_view kWords[] = {
      "CM_",          "BA_DEF_",         "BA_DEF_DEF_", "BA_",          "VAL_",
      "VAL_TABLE_",   "BO_TX_BU_",       "EV_",         "SIG_VALTYPE_", "BA_DEF_REL_",
      "BA_REL_",      "BA_DEF_DEF_REL_", "SIG_GROUP_",  "SGTYPE_",      "SIG_TYPE_REF_",
      "ENVVAR_DATA_", "SIG_MUL_VAL_",    "BU_SG_REL_",  "BU_EV_REL_",   "BU_BO_REL_"};
  for (std::string_view w : kWords) {
    if (kw == w) return true;
  }
  return false;
}

// Every statement keyword the parser knows (the start of a statement).
bool IsKeyword(std::string_view kw) {
  return kw == "VERSION" || kw == "NS_" || kw == "BS_" || kw == "BU_" || kw == "BO_" ||
         kw == "SG_" || SemicolonStatement(kw);
}

class Parser {
 public:
  Parser(const std::string& path, Dbc* out, std::string* error)
      : path_(path), out_(out), error_(error) {}

  bool Fail(int line, const std::string& why) {
    *error_ = Where(path_, line) + why;
    return false;
  }

  bool Message(Scanner& sc, int line) {
    DbcMessage m;
    m.line = line;
    std::uint64_t id = 0, dlc = 0;
    if (!sc.Unsigned(0xFFFFFFFFULL, &id)) return Fail(line, "BO_: expected the message id");
    if (!sc.Ident(&m.name)) return Fail(line, "BO_: expected the message name");
    if (!sc.Eat(':')) return Fail(line, "BO_ " + m.name + ": expected ':' after the name");
    if (!sc.Unsigned(64, &dlc)) return Fail(line, "BO_ " + m.name + ": expected the length");
    if (dlc > 8) {
      return Fail(
          line, "BO_ " + m.name + ": length " + std::to_string(dlc) + " bytes (classic CAN: 0..8)");
    }
    std::string tx;
    (void)sc.Ident(&tx);
    m.extended = (id & kExtendedFlag) != 0;
    m.id = static_cast<std::uint32_t>(id & ~kExtendedFlag);
    if (m.extended ? m.id > 0x1FFFFFFFU : m.id > 0x7FFU) {
      return Fail(line, "BO_ " + m.name + ": id " + std::to_string(id) + " beyond " +
                            (m.extended ? "29" : "11") + " bits (an extended id has bit 31 set)");
    }
    m.dlc = static_cast<int>(dlc);
    for (const DbcMessage& o : out_->messages) {
      if (o.name == m.name) {
        return Fail(line, "message " + m.name + " defined twice (first at line " +
                              std::to_string(o.line) + ")");
      }
      if (o.id == m.id && o.extended == m.extended) {
        return Fail(line, "message " + m.name + " has the id of " + o.name);
      }
    }
    out_->messages.push_back(std::move(m));
    return true;
  }

  bool Signal(Scanner& sc, int line) {
    if (out_->messages.empty()) return Fail(line, "SG_ outside a message (no BO_ before it)");
    DbcMessage& m = out_->messages.back();
    DbcSignal s;
    s.line = line;
    if (!sc.Ident(&s.name)) return Fail(line, "SG_: expected the signal name");
    const std::string at = "SG_ " + m.name + "." + s.name + ": ";
    std::string mux;
    if (sc.Ident(&mux)) {
      return Fail(line, at + "multiplexed signals ('" + mux + "') are not supported");
    }
    std::uint64_t start = 0, length = 0;
    double factor = 0, offset = 0, min = 0, max = 0;
    if (!sc.Eat(':')) return Fail(line, at + "expected ':'");
    if (!sc.Unsigned(511, &start) || !sc.Eat('|') || !sc.Unsigned(512, &length) || !sc.Eat('@')) {
      return Fail(line, at + "expected <start>|<length>@");
    }
    const bool intel = sc.Eat('1');
    if (!intel && !sc.Eat('0'))
      return Fail(line, at + "byte order must be @0 (Motorola) or @1 (Intel)");
    const bool is_signed = sc.Eat('-');
    if (!is_signed && !sc.Eat('+')) return Fail(line, at + "expected + (unsigned) or - (signed)");
    if (!sc.Eat('(') || !sc.Number(&factor) || !sc.Eat(',') || !sc.Number(&offset) ||
        !sc.Eat(')')) {
      return Fail(line, at + "expected (<factor>,<offset>)");
    }
    if (!sc.Eat('[') || !sc.Number(&min) || !sc.Eat('|') || !sc.Number(&max) || !sc.Eat(']')) {
      return Fail(line, at + "expected [<min>|<max>]");
    }
    if (!sc.Quoted(&s.unit)) return Fail(line, at + "expected the unit in double quotes");
    if (length < 1 || length > 64) {
      return Fail(line, at + "length " + std::to_string(length) + " bits (1..64)");
    }
    if (factor == 0.0) return Fail(line, at + "factor 0");
    if (min > max) return Fail(line, at + "min > max");
    s.layout.start_bit = static_cast<std::uint16_t>(start);
    s.layout.length = static_cast<std::uint8_t>(length);
    s.layout.order = intel ? protocol::ByteOrder::kIntel : protocol::ByteOrder::kMotorola;
    s.layout.is_signed = is_signed;
    s.layout.factor = factor;
    s.layout.offset = offset;
    s.layout.min = min;
    s.layout.max = max;
    std::uint64_t mask = 0;
    if (!protocol::SignalFits(s.layout, m.dlc) || !protocol::SignalMask(s.layout, &mask)) {
      return Fail(line, at + "does not fit the message's " + std::to_string(m.dlc) + " bytes");
    }
    for (const DbcSignal& o : m.signals) {
      std::uint64_t om = 0;
      (void)protocol::SignalMask(o.layout, &om);
      if (o.name == s.name) return Fail(line, at + "defined twice in " + m.name);
      if ((om & mask) != 0) {
        return Fail(line, at + "overlaps " + o.name + " (line " + std::to_string(o.line) + ")");
      }
    }
    m.signals.push_back(std::move(s));
    return true;
  }

  // BA_ "GenMsgCycleTime" BO_ <id> <ms>; other attributes are read over.
  bool Attribute(Scanner& sc, int line) {
    std::string name, kind;
    if (!sc.Quoted(&name)) return Fail(line, "BA_: expected the attribute name in quotes");
    if (name != "GenMsgCycleTime") return true;
    std::uint64_t id = 0;
    double ms = 0;
    if (!sc.Ident(&kind) || kind != "BO_" || !sc.Unsigned(0xFFFFFFFFULL, &id) || !sc.Number(&ms)) {
      return Fail(line, "BA_ \"GenMsgCycleTime\": expected BO_ <id> <milliseconds>");
    }
    if (ms < 0 || ms > 3.6e6 || ms != std::floor(ms)) {
      return Fail(line, "BA_ \"GenMsgCycleTime\": " + std::to_string(ms) + " ms (0..3600000)");
    }
    pending_cycle_.push_back({id, static_cast<int>(ms), line});
    return true;
  }

  bool Finish() {
    for (const auto& c : pending_cycle_) {
      const bool ext = (c.id & kExtendedFlag) != 0;
      const auto id = static_cast<std::uint32_t>(c.id & ~kExtendedFlag);
      bool found = false;
      for (DbcMessage& m : out_->messages) {
        if (m.id == id && m.extended == ext) {
          m.cycle_time_ms = c.ms;
          found = true;
        }
      }
      if (!found)
        return Fail(c.line, "GenMsgCycleTime of message id " + std::to_string(c.id) +
                                ", which no BO_ defines");
    }
    return true;
  }

 private:
  struct Cycle {
    std::uint64_t id;
    int ms;
    int line;
  };
  const std::string& path_;
  Dbc* out_;
  std::string* error_;
  std::vector<Cycle> pending_cycle_;
};

}  // namespace

const DbcSignal* DbcMessage::Find(std::string_view signal) const {
  for (const DbcSignal& s : signals) {
    if (s.name == signal) return &s;
  }
  return nullptr;
}

const DbcMessage* Dbc::Find(std::string_view message) const {
  for (const DbcMessage& m : messages) {
    if (m.name == message) return &m;
  }
  return nullptr;
}

bool ParseDbc(std::string_view text, const std::string& path, Dbc* out, std::string* error) {
  *out = Dbc{};
  out->path = path;
  out->digest = TextDigest(text);
  Parser p(path, out, error);
  // A UTF-8 byte-order mark (editors on Windows write one) is no text of the file.
  if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  std::size_t pos = 0;
  int line = 1;
  while (pos < text.size()) {
    // One statement: a line, or up to the ';' that ends a semicolon statement (outside quotes).
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view first = text.substr(pos, eol - pos);
    Scanner head(first, line);
    std::string kw;
    if (!head.Ident(&kw)) {
      if (!Scanner(first, line).AtEnd()) {
        // Lines of the NS_ block are bare keywords (caught above); anything else is not DBC.
        return p.Fail(line, "unexpected text '" + std::string(first.substr(0, 40)) + "'");
      }
      pos = eol + 1;
      ++line;
      continue;
    }
    std::size_t end = eol;
    if (!IsKeyword(kw)) {
      return p.Fail(line, "unexpected text '" + std::string(first.substr(0, 40)) +
                              "' (not a DBC keyword this parser knows)");
    }
    if (kw == "NS_") {
      // The new-symbols list: the indented lines that follow.
      while (end < text.size()) {
        const std::size_t next = end + 1;
        if (next >= text.size()) break;
        std::size_t next_eol = text.find('\n', next);
        if (next_eol == std::string_view::npos) next_eol = text.size();
        const std::string_view l = text.substr(next, next_eol - next);
        if (!l.empty() && !std::isspace(static_cast<unsigned char>(l[0]))) break;
        end = next_eol;
      }
    } else if (SemicolonStatement(kw)) {
      // Up to its ';' outside quotes. It may span lines (a comment's text does), but a line
      // that begins with a keyword is the next statement: this one lacks its ';' (else it
      // would swallow the statements that follow).
      bool quoted = false;
      std::size_t i = pos;
      int at = line;
      for (; i < text.size(); ++i) {
        if (text[i] == '"') quoted = !quoted;
        if (text[i] == ';' && !quoted) break;
        if (text[i] != '\n' || quoted) continue;
        ++at;
        std::string next_kw;
        Scanner next(text.substr(i + 1, text.find('\n', i + 1) - (i + 1)), at);
        if (next.Ident(&next_kw) && IsKeyword(next_kw)) {
          return p.Fail(line, kw + " statement without its closing ';' (line " +
                                  std::to_string(at) + " begins the next statement)");
        }
      }
      if (i >= text.size()) return p.Fail(line, kw + " statement without its closing ';'");
      end = i;
    }
    std::string_view stmt = text.substr(pos, end - pos);
    Scanner sc(stmt, line);
    std::string k;
    (void)sc.Ident(&k);
    if (kw == "BO_") {
      if (!p.Message(sc, line)) return false;
    } else if (kw == "SG_") {
      if (!p.Signal(sc, line)) return false;
    } else if (kw == "BA_") {
      if (!p.Attribute(sc, line)) return false;
    } else if (kw == "SIG_VALTYPE_") {
      return p.Fail(line, "SIG_VALTYPE_ (IEEE float signals) is not supported");
    }
    // Any other keyword (VERSION, NS_ and its list, BS_, BU_, CM_, BA_DEF_, VAL_, ...): read over.
    for (std::size_t i = pos; i < end && i < text.size(); ++i) {
      if (text[i] == '\n') ++line;
    }
    pos = end + 1;
    if (end < text.size() && text[end] == '\n') ++line;
  }
  return p.Finish();
}

bool LoadDbc(const std::string& path, Dbc* out, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, kMaxDbcBytes, &text, error)) return false;
  return ParseDbc(text, path, out, error);
}

}  // namespace mrd::profile
