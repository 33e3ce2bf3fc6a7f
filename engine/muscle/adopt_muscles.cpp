// Muscles of a donor model carried onto a target model of the same bones (muscle/adopt_muscles.hpp).
#include "muscle/adopt_muscles.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "sim/system.hpp"

namespace kneesim::muscle {

namespace {

// Donor body index -> (target body index, X_TD); target index -1 when the target lacks it.
struct BodyMap {
  std::vector<int> target;
  std::vector<Eigen::Isometry3d> X_TD;
};

BodyMap makeBodyMap(const model::Model& target, const model::Model& donor, const std::vector<BodyCorrespondence>& map,
                    const SourceLocation& where) {
  BodyMap m;
  m.target.assign(donor.bodies.size(), -1);
  m.X_TD.assign(donor.bodies.size(), Eigen::Isometry3d::Identity());
  for (size_t b = 0; b < donor.bodies.size(); ++b) m.target[b] = target.findBody(donor.bodies[b].name);
  for (const BodyCorrespondence& c : map) {
    const int d = donor.findBody(c.donor_body), t = target.findBody(c.target_body);
    if (d < 0) throw InputError(where, "expected a body of the donor model " + donor.source_file + ", got '" + c.donor_body + "'");
    if (t < 0) throw InputError(where, "expected a body of the target model " + target.source_file + ", got '" + c.target_body + "'");
    m.target[size_t(d)] = t;
    m.X_TD[size_t(d)] = c.X_TD;
  }
  return m;
}

// The target coordinate of donor coordinate @p c by name (-1: none; c < 0 stays -1).
int mapCoordinate(const model::Model& target, const model::Model& donor, int c) {
  return c < 0 ? -1 : target.findCoordinate(donor.coordinates[size_t(c)].name);
}

}  // namespace

BodyCorrespondence calcDefaultPoseCorrespondence(const model::Model& target, const model::Model& donor,
                                                 const std::string& body, const SourceLocation& where) {
  const int bt = target.findBody(body), bd = donor.findBody(body);
  if (bt < 0 || bd < 0) throw InputError(where, "expected a body of both models, got '" + body + "'");
  const int jt = target.findParentJoint(bt), jd = donor.findParentJoint(bd);
  if (jt < 0 || jd < 0) throw InputError(where, "expected body '" + body + "' to have a parent joint in both models");
  const model::Joint& J = target.joints[size_t(jt)];
  const std::string& parent = target.bodies[size_t(J.parent_body)].name;
  const int pd = donor.findBody(parent);
  if (pd < 0) throw InputError(where, "expected the donor model to have body '" + parent + "' (the parent of '" + body + "')");
  // The donor's pose at its default coordinates, couplers applied (as the knee model tool does).
  auto donor_ptr = std::make_shared<model::Model>(donor);
  const sim::System sys(donor_ptr);
  auto ws = sys.createWorkspace();
  Eigen::VectorXd q = sys.getDefaultCoordinates();
  for (const model::CoordinateCoupler& cc : donor.couplers) {
    double x[6];
    for (size_t k = 0; k < cc.independents.size() && k < 6; ++k) x[k] = q[cc.independents[k]];
    q[cc.dependent] = cc.scale_factor * cc.function->calcValue(x);
  }
  sys.realizePosition(*ws, q);
  const Eigen::Isometry3d X_PB_donor = sys.getBodyPose(*ws, pd).inverse() * sys.getBodyPose(*ws, bd);
  const Eigen::Isometry3d X_PB_target = J.X_PF * J.X_BM.inverse();
  return {body, body, X_PB_target.inverse() * X_PB_donor};
}

AdoptedMuscles adoptMuscles(const model::Model& target, const model::Model& donor,
                            const std::vector<BodyCorrespondence>& map, const std::vector<std::string>& exclude,
                            const SourceLocation& where) {
  for (const std::string& e : exclude)
    if (donor.findMuscle(e) < 0)
      throw InputError(where, "expected a muscle of " + donor.source_file + " to exclude, got '" + e + "'");
  const BodyMap bodies = makeBodyMap(target, donor, map, where);
  auto out = std::make_shared<model::Model>(target);
  AdoptedMuscles result;
  std::map<int, int> wrap_index;  // donor wrap object -> out's
  std::set<std::string> names;
  for (const model::Muscle& m : target.muscles) names.insert(m.name);
  for (const model::Muscle& mu : donor.muscles) {
    if (!mu.enabled) continue;
    if (std::find(exclude.begin(), exclude.end(), mu.name) != exclude.end()) {
      result.left_out.push_back(mu.name + ": excluded by name");
      continue;
    }
    std::string why;
    model::Muscle m = mu;
    for (model::PathPoint& p : m.path.points) {
      const int db = p.body, b = bodies.target[size_t(db)];
      if (b < 0) {
        why = "the target has no body '" + donor.bodies[size_t(db)].name + "'";
        break;
      }
      p.p_BP = bodies.X_TD[size_t(db)] * p.p_BP;
      p.body = b;
      const int c = mapCoordinate(target, donor, p.coordinate);
      if (p.coordinate >= 0 && c < 0) why = "the target has no coordinate '" + donor.coordinates[size_t(p.coordinate)].name + "'";
      p.coordinate = c;
      for (int k = 0; k < 3; ++k) {
        const int ck = mapCoordinate(target, donor, p.location_coordinates[size_t(k)]);
        if (p.location_coordinates[size_t(k)] >= 0 && ck < 0) why = "the target lacks a moving point's coordinate";
        // A moving point's functions give the location in the donor's frame: only identity maps.
        if (p.type == model::PathPointType::Moving && !bodies.X_TD[size_t(db)].isApprox(Eigen::Isometry3d::Identity()))
          why = "a moving point on a re-framed body";
        p.location_coordinates[size_t(k)] = ck;
      }
      if (!why.empty()) break;
    }
    for (const model::PathWrap& w : m.path.wraps) {
      const model::WrapObject& wo = donor.wrap_objects[size_t(w.wrap_object)];
      if (bodies.target[size_t(wo.body)] < 0) why = "the target has no body '" + donor.bodies[size_t(wo.body)].name + "' (wrap " + wo.name + ")";
    }
    if (!why.empty()) {
      result.left_out.push_back(mu.name + ": " + why);
      continue;
    }
    for (model::PathWrap& w : m.path.wraps) {
      auto it = wrap_index.find(w.wrap_object);
      if (it == wrap_index.end()) {
        model::WrapObject wo = donor.wrap_objects[size_t(w.wrap_object)];
        wo.X_BW = bodies.X_TD[size_t(wo.body)] * wo.X_BW;
        wo.body = bodies.target[size_t(wo.body)];
        out->wrap_objects.push_back(wo);
        it = wrap_index.emplace(w.wrap_object, int(out->wrap_objects.size()) - 1).first;
      }
      w.wrap_object = it->second;
    }
    if (!names.insert(m.name).second) throw InputError(where, "expected muscle names new to the target, got '" + m.name + "' twice");
    out->muscles.push_back(std::move(m));
    result.adopted.push_back(mu.name);
  }
  out->finalize();
  result.model = out;
  return result;
}

}  // namespace kneesim::muscle
