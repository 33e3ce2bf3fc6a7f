#pragma once
// The checks a URDF passes before urdfdom reads it (engine/model/urdf.cpp). urdfdom 3.0 leaks what it
// was building when it rejects some inputs (a geometry attribute that does not parse, a joint loop),
// and it only prints a console message for others, so everything it would reject is refused here
// first, with file and line, and urdfdom only ever sees files it reads whole.

#include <string>
#include <vector>

#include "core/xml.hpp"

namespace kneesim::model::urdf_check {

extern const char* const kJointTypes;  ///< the URDF joint types kneesim reads, for messages

/// Our own pass over the XML (tinyxml2): names, numbers as urdfdom reads them, geometry, joint types
/// and links, and a tree of links (no loop, one parent joint per link). Returns the link and joint
/// elements in file order.
void validate(const xml::Document& doc, std::vector<xml::Node>& links, std::vector<xml::Node>& joints);

/// urdfdom reads @p text with its own XML parser (TinyXML), which reads some text differently from
/// tinyxml2 (it drops an '&' that starts no entity, and reads some bytes otherwise). The same parser
/// reads the text here, before urdfdom does, and every link, joint, parent, child and mimic name must
/// be what validate() checked: a joint loop in urdfdom's reading alone would leak its model.
void sameReadingAsUrdfdom(const std::string& text, const std::vector<xml::Node>& links,
                          const std::vector<xml::Node>& joints);

/// The one-line error for a name urdfdom reads differently.
[[noreturn]] void differs(const xml::Node& n, const std::string& value);

}  // namespace kneesim::model::urdf_check
