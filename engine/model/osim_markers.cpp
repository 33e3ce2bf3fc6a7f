// The .osim reader's markers, on bodies (3.x) or on any frame (4.x).
#include "model/osim_reader_internal.hpp"

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

void OsimReader::readMarkers(const Node& model_el, bool v4) {
  std::set<std::string> names;
  std::vector<std::pair<Node, std::string>> items;  // element, component path
  for (const Node& mk : model_el.child("MarkerSet").child("objects").children())
    items.emplace_back(mk, "/markerset/" + mk.nameAttr());
  for (const Node& mk : model_el.child("components").children("Marker")) items.emplace_back(mk, "/" + mk.nameAttr());
  for (const auto& [mk, path] : items) {
    if (mk.name() != "Marker") {
      ignore(mk, "MarkerSet");
      continue;
    }
    Marker marker;
    marker.name = mk.nameAttr();
    if (marker.name.empty()) mk.fail("expected a name attribute on <Marker>, got none");
    if (!names.insert(marker.name).second) mk.fail("duplicate marker name '" + marker.name + "'");
    const Vec3 location = mk.childVec3("location", Vec3::Zero());
    if (Node pf = findSocket(mk, {"parent_frame"}); pf && v4) {
      const auto frame = resolveFrame(pf.text(), path, pf);
      marker.body = frame.first;
      marker.p_BM = frame.second * location;  // offset frames are expressed in the body frame
    } else {
      Node b = mk.requireChild("body");
      auto it = body_index_.find(b.text());
      if (it == body_index_.end()) {
        std::vector<std::string> bn;
        for (const Body& body : m_->bodies) bn.push_back(body.name);
        b.fail("unknown body '" + b.text() + "' (expected one of " + listNames(bn) + ")");
      }
      marker.body = it->second;
      marker.p_BM = location;
    }
    marker.fixed = mk.childBool("fixed", false);
    m_->markers.push_back(std::move(marker));
  }
}

}  // namespace kneesim::model::osim
