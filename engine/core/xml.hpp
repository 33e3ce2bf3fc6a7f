#pragma once
// A thin read-only layer over tinyxml2 that turns every parse problem into a one-line
// InputError naming the file, the line and the element path.

#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/error.hpp"

namespace tinyxml2 {
class XMLDocument;
class XMLElement;
}  // namespace tinyxml2

namespace kneesim::xml {

class Document;

/// A read-only view of one XML element of a loaded Document.
class Node {
 public:
  Node() = default;
  Node(const Document* doc, const tinyxml2::XMLElement* el) : doc_(doc), el_(el) {}

  explicit operator bool() const { return el_ != nullptr; }
  /// Tag name.
  std::string name() const;
  /// Value of attribute @p key, or std::nullopt.
  std::optional<std::string> attr(const char* key) const;
  /// The `name` attribute, or "" (OpenSim objects are named by it).
  std::string nameAttr() const;
  /// First child element with tag @p tag, or a null Node.
  Node child(const char* tag) const;
  /// First child element with tag @p tag; throws "missing element <tag>" if absent.
  Node requireChild(const char* tag) const;
  /// All child elements (any tag) in document order.
  std::vector<Node> children() const;
  /// All child elements with tag @p tag.
  std::vector<Node> children(const char* tag) const;
  /// Trimmed text content ("" if none).
  std::string text() const;

  /// Text as one number; throws "expected a number, got '...'" otherwise.
  double toDouble() const;
  /// Text as integer.
  long toInt() const;
  /// Text as an integer from @p lo to @p hi (by default the largest int); throws "expected an
  /// integer from lo to hi, got '...'" otherwise (a setting narrowed to int is checked here, not
  /// wrapped beyond 2^31).
  int toIntIn(int lo, int hi = std::numeric_limits<int>::max()) const;
  /// Text as "true"/"false".
  bool toBool() const;
  /// Text as whitespace-separated numbers.
  std::vector<double> toDoubles() const;
  /// Text as exactly three numbers.
  Eigen::Vector3d toVec3() const;
  /// Text as whitespace-separated words.
  std::vector<std::string> toWords() const;
  /// Text 'first last step' (finite, step > 0, last >= first) as the values first, first + step,
  /// ... up to last; throws when they would be more than @p max_count (counted before any is made).
  std::vector<double> toStepRange(int max_count) const;

  /// Child text helpers: return @p fallback when the child is absent or empty.
  double childDouble(const char* tag, double fallback) const;
  bool childBool(const char* tag, bool fallback) const;
  std::string childText(const char* tag, const std::string& fallback = "") const;
  Eigen::Vector3d childVec3(const char* tag, const Eigen::Vector3d& fallback) const;

  /// 1-based line number in the file.
  int line() const;
  /// Path such as "OpenSimDocument/Model/BodySet/objects/Body[femur]".
  std::string path() const;
  /// File, line and element path of this node.
  SourceLocation where() const;
  /// Throws InputError at this node with @p message.
  [[noreturn]] void fail(const std::string& message) const;

  const tinyxml2::XMLElement* raw() const { return el_; }
  const Document* document() const { return doc_; }

 private:
  const Document* doc_ = nullptr;
  const tinyxml2::XMLElement* el_ = nullptr;
};

/// A parsed XML file. Throws InputError ("file:line: XML error: ...") on malformed input.
class Document {
 public:
  /// Loads and parses @p path.
  static std::unique_ptr<Document> load(const std::string& path);
  /// Parses @p text; @p label names it in error messages.
  static std::unique_ptr<Document> parse(const std::string& text, const std::string& label);
  ~Document();

  /// The root element.
  Node root() const;
  /// The file path or label given when loading.
  const std::string& getPath() const { return path_; }

  /// Moves every child element of @p from, in order, to the end of @p to's children (both
  /// elements of this document), as readers that upgrade an old layout the way OpenSim does need.
  /// The moved elements keep their line numbers.
  void moveChildren(const Node& from, const Node& to);
  /// Renames element @p el (of this document) to @p tag.
  void rename(const Node& el, const std::string& tag);

 private:
  Document() = default;
  std::string path_;
  std::unique_ptr<tinyxml2::XMLDocument> doc_;
};

// Helpers for kneesim's setup files (tools' XML files in OpenSim's style).

/// The element @p tag of a setup file: the root, or the root's child @p tag (inside
/// <OpenSimDocument>). Throws InputError at the root when neither is there.
Node requireSetupElement(const Document& doc, const char* tag);

/// A setup file opened for reading: its document, its folder (relative paths in it start there)
/// and its tool element (requireSetupElement). `tool` points into `doc`: keep them together.
struct SetupFile {
  std::unique_ptr<Document> doc;
  std::string dir;
  Node tool;
};

/// Loads the setup file @p path, finds its element @p tag (requireSetupElement) and checks that
/// every child of it is in @p known (checkChildren). Throws InputError otherwise.
SetupFile openSetupFile(const std::string& path, const char* tag, const std::set<std::string>& known);

/// Throws InputError at the first child of @p node whose tag is not in @p known, listing them.
void checkChildren(const Node& node, const std::set<std::string>& known);

/// @p s with XML's five special characters (& < > " ') written as entities, for text and
/// attribute values.
std::string escape(const std::string& s);

/// A path @p p read from a setup file in folder @p base_dir: @p p itself if empty or absolute,
/// else base_dir/p, lexically normalised.
std::string resolvePath(const std::string& base_dir, const std::string& p);

}  // namespace kneesim::xml
