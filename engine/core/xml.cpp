#include "core/xml.hpp"

#include <cmath>
#include <filesystem>

#include <tinyxml2.h>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::xml {

std::string Node::name() const { return el_ ? el_->Name() : ""; }

std::optional<std::string> Node::attr(const char* key) const {
  const char* v = el_ ? el_->Attribute(key) : nullptr;
  if (!v) return std::nullopt;
  return std::string(v);
}

std::string Node::nameAttr() const { return attr("name").value_or(""); }

Node Node::child(const char* tag) const {
  return Node(doc_, el_ ? el_->FirstChildElement(tag) : nullptr);
}

Node Node::requireChild(const char* tag) const {
  Node c = child(tag);
  if (!c) fail(std::string("missing element <") + tag + ">");
  return c;
}

std::vector<Node> Node::children() const {
  std::vector<Node> out;
  if (!el_) return out;
  for (auto* c = el_->FirstChildElement(); c; c = c->NextSiblingElement()) out.emplace_back(doc_, c);
  return out;
}

std::vector<Node> Node::children(const char* tag) const {
  std::vector<Node> out;
  if (!el_) return out;
  for (auto* c = el_->FirstChildElement(tag); c; c = c->NextSiblingElement(tag)) out.emplace_back(doc_, c);
  return out;
}

std::string Node::text() const {
  if (!el_) return "";
  const char* t = el_->GetText();
  return t ? std::string(trim(t)) : std::string();
}

double Node::toDouble() const { return parseDouble(text(), where()); }
long Node::toInt() const { return parseInt(text(), where()); }
int Node::toIntIn(int lo, int hi) const {
  const long v = toInt();
  if (v < lo || v > hi)
    fail("expected an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + ", got '" + text() + "'");
  return static_cast<int>(v);
}
bool Node::toBool() const { return parseBool(text(), where()); }

std::vector<double> Node::toDoubles() const {
  std::vector<double> out;
  const std::string t = text();
  for (auto w : splitWhitespace(t)) out.push_back(parseDouble(w, where()));
  return out;
}

Eigen::Vector3d Node::toVec3() const {
  const auto v = toDoubles();
  if (v.size() != 3)
    fail("expected 3 numbers, got " + std::to_string(v.size()) + " ('" + text() + "')");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

std::vector<std::string> Node::toWords() const {
  std::vector<std::string> out;
  const std::string t = text();
  for (auto w : splitWhitespace(t)) out.emplace_back(w);
  return out;
}

std::vector<double> Node::toStepRange(int max_count) const {
  const std::vector<double> r = toDoubles();
  if (r.size() != 3 || !(r[2] > 0) || !(r[1] >= r[0]) || !std::isfinite(r[0]) || !std::isfinite(r[1]))
    fail("expected 'first last step' with step > 0 and last >= first, got '" + text() + "'");
  // Counted in double: the count of '0 1e300 1e-300' is no int (converting it is undefined).
  const double count = std::floor((r[1] - r[0]) / r[2] + 1e-9) + 1;
  if (!(count <= max_count))
    fail("expected at most " + std::to_string(max_count) + " values, got " + formatSignificant(count, 6) + " ('" +
         text() + "')");
  std::vector<double> out(static_cast<size_t>(count));
  for (size_t k = 0; k < out.size(); ++k) out[k] = r[0] + double(k) * r[2];  // no accumulated rounding
  return out;
}

double Node::childDouble(const char* tag, double fallback) const {
  Node c = child(tag);
  return (c && !c.text().empty()) ? c.toDouble() : fallback;
}
bool Node::childBool(const char* tag, bool fallback) const {
  Node c = child(tag);
  return (c && !c.text().empty()) ? c.toBool() : fallback;
}
std::string Node::childText(const char* tag, const std::string& fallback) const {
  Node c = child(tag);
  return c ? c.text() : fallback;
}
Eigen::Vector3d Node::childVec3(const char* tag, const Eigen::Vector3d& fallback) const {
  Node c = child(tag);
  return (c && !c.text().empty()) ? c.toVec3() : fallback;
}

int Node::line() const { return el_ ? el_->GetLineNum() : 0; }

std::string Node::path() const {
  std::string p;
  for (const tinyxml2::XMLNode* n = el_; n; n = n->Parent()) {
    const tinyxml2::XMLElement* e = n->ToElement();
    if (!e) break;
    std::string part = e->Name();
    if (const char* nm = e->Attribute("name"); nm && *nm) part += std::string("[") + nm + "]";
    p = p.empty() ? part : part + "/" + p;
  }
  return p;
}

SourceLocation Node::where() const { return {doc_ ? doc_->getPath() : "", line(), path()}; }

void Node::fail(const std::string& message) const { throw InputError(where(), message); }

Document::~Document() = default;

std::unique_ptr<Document> Document::load(const std::string& path) {
  return parse(readFileText(path), path);
}

std::unique_ptr<Document> Document::parse(const std::string& text, const std::string& label) {
  std::unique_ptr<Document> d(new Document());
  d->path_ = label;
  d->doc_ = std::make_unique<tinyxml2::XMLDocument>();
  if (d->doc_->Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS) {
    std::string msg = d->doc_->ErrorStr() ? d->doc_->ErrorStr() : "parse error";
    // tinyxml2 prefixes "Error=XML_ERROR_... ErrorID=N (0xN) Line number=N: "; keep what follows.
    if (auto pos = msg.find(": "); pos != std::string::npos && msg.find("Line number") != std::string::npos)
      msg = msg.substr(pos + 2);
    throw InputError({label, d->doc_->ErrorLineNum(), ""},
                     std::string("malformed XML (") + d->doc_->ErrorName() + "): " + msg);
  }
  if (!d->doc_->RootElement()) throw InputError({label, 0, ""}, "XML file has no root element");
  return d;
}

Node Document::root() const { return Node(this, doc_->RootElement()); }

namespace {
// The element behind @p n, mutable: @p n must point into @p doc (Nodes are read-only views).
tinyxml2::XMLElement* mutableElement(const Document* doc, const Node& n) {
  KNEESIM_ASSERT(n && n.document() == doc);
  return const_cast<tinyxml2::XMLElement*>(n.raw());
}
}  // namespace

void Document::moveChildren(const Node& from, const Node& to) {
  tinyxml2::XMLElement* f = mutableElement(this, from);
  tinyxml2::XMLElement* t = mutableElement(this, to);
  // InsertEndChild unlinks a node that is already in the document before inserting it.
  while (tinyxml2::XMLElement* c = f->FirstChildElement()) t->InsertEndChild(c);
}

void Document::rename(const Node& el, const std::string& tag) { mutableElement(this, el)->SetName(tag.c_str()); }

Node requireSetupElement(const Document& doc, const char* tag) {
  const Node root = doc.root();
  const Node el = root.name() == tag ? root : root.child(tag);
  if (!el) root.fail(std::string("no <") + tag + "> element (expected it as the root or inside <OpenSimDocument>)");
  return el;
}

SetupFile openSetupFile(const std::string& path, const char* tag, const std::set<std::string>& known) {
  SetupFile f;
  f.doc = Document::load(path);
  f.dir = std::filesystem::path(path).parent_path().string();
  f.tool = requireSetupElement(*f.doc, tag);
  checkChildren(f.tool, known);
  return f;
}

void checkChildren(const Node& node, const std::set<std::string>& known) {
  for (const Node& c : node.children())
    if (!known.count(c.name())) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      c.fail("unknown element <" + c.name() + "> in <" + node.name() + "> (expected one of " + list + ")");
    }
}

std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string resolvePath(const std::string& base_dir, const std::string& p) {
  if (p.empty()) return p;
  const std::filesystem::path path(p);
  return path.is_absolute() ? p : (std::filesystem::path(base_dir) / path).lexically_normal().string();
}

}  // namespace kneesim::xml
