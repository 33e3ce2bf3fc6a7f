// Python bindings of contact-law identification (Dao & Pouletaut 2015, section 2.5.2):
// kneesim.fit_contact_law runs identify::fit on trials given as dicts of NumPy arrays and returns
// kneesim.FitResult (parameters with their intervals, derived quantities such as Hertz's K, fit
// statistics, the whole report as a dict, and prediction of other trials).

#include <memory>

#include <nlohmann/json.hpp>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "identify/fit.hpp"
#include "identify/report_json.hpp"
#include "plugin/registry.hpp"

namespace kneesim::python {

namespace {

/// A parsed JSON value as Python objects (through the json module: NaN-free, as the engine writes it).
py::object toPython(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

/// A trial from a dict: name, time, channels {name: values}, measured_force, and optionally
/// weight and windows [(begin, end), ...].
identify::Trial toTrial(const py::handle& item, size_t index) {
  const std::string what = "fit_contact_law/trials[" + std::to_string(index) + "]";
  if (!py::isinstance<py::dict>(item))
    throw InputError({"", 0, what}, "expected a dict with name, time, channels and measured_force");
  const py::dict d = py::reinterpret_borrow<py::dict>(item);
  for (const char* key : {"time", "channels", "measured_force"})
    if (!d.contains(key)) throw InputError({"", 0, what}, std::string("expected a key '") + key + "', got none");
  identify::Trial t;
  t.name = d.contains("name") ? d["name"].cast<std::string>() : "trial" + std::to_string(index + 1);
  t.source = {"", 0, what};
  t.time = toVector(Array::ensure(d["time"]), what + "/time");
  t.measured_force = toVector(Array::ensure(d["measured_force"]), what + "/measured_force");
  for (const auto& [name, values] : d["channels"].cast<py::dict>()) {
    const std::string n = name.cast<std::string>();
    t.channels[n] = toVector(Array::ensure(values), what + "/channels/" + n);
  }
  if (d.contains("weight")) t.weight = toVector(Array::ensure(d["weight"]), what + "/weight");
  if (d.contains("windows"))
    for (const auto& [b, e] : d["windows"].cast<std::vector<std::pair<double, double>>>()) t.windows.push_back({b, e});
  return t;
}

py::tuple toTuple(const identify::Interval& i) { return py::make_tuple(i.lower, i.upper); }

/// What a parameter and a derived quantity both have: value, unit and the three intervals.
template <class Result>
py::dict describe(const Result& r) {
  py::dict d;
  d["value"] = r.value;
  d["unit"] = r.unit;
  d["ci_asymptotic"] = toTuple(r.ci_asymptotic);
  d["ci_profile"] = toTuple(r.ci_profile);
  d["ci_bootstrap"] = toTuple(r.ci_bootstrap);
  return d;
}

/// kneesim.FitResult: the report and what predicting other trials needs (the law and its plugin).
struct FitResult {
  std::shared_ptr<plugin::Registry> registry;  // holds the law's table
  std::shared_ptr<identify::ContactLaw> law;
  identify::FitOptions options;
  identify::FitReport report;

  py::dict getParameters() const {
    py::dict out;
    for (const identify::ParameterResult& p : report.parameters) {
      py::dict d = describe(p);
      d["status"] = identify::toString(p.status);
      d["value_source"] = p.value_source;
      d["start"] = p.start;
      d["bounds"] = py::make_tuple(p.lower, p.upper);
      d["at_bound"] = p.at_bound;
      out[py::str(p.name)] = d;
    }
    return out;
  }

  py::dict getDerived() const {
    py::dict out;
    for (const identify::DerivedResult& q : report.derived) {
      py::dict d = describe(q);
      d["identified"] = q.identified;
      out[py::str(q.name)] = d;
    }
    return out;
  }

  py::dict predict(const py::object& trial) const {
    const identify::Trial t = toTrial(trial, 0);
    identify::PredictionReport p;
    {
      py::gil_scoped_release release;
      p = identify::predict(*law, report.getValues(), t, options);
    }
    py::dict d;
    d["time"] = toArray(p.time);
    d["measured"] = toArray(p.measured);
    d["predicted"] = toArray(p.predicted);
    d["metrics"] = toPython(identify::toJson(p.metrics));
    return d;
  }
};

FitResult fitContactLaw(const py::list& trials, const std::string& law, const py::object& plugins,
                        const std::vector<std::string>& free_parameters,
                        const std::map<std::string, double>& parameter_values,
                        const std::map<std::string, std::pair<double, double>>& bounds,
                        const std::map<std::string, double>& assumed_values, double body_mass,
                        double confidence_level, int bootstrap_samples, const std::string& bootstrap_mode,
                        bool profile, unsigned long long seed) {
  std::vector<identify::Trial> data;
  for (size_t i = 0; i < trials.size(); ++i) data.push_back(toTrial(trials[i], i));
  FitResult r;
  identify::FitOptions& o = r.options;
  o.free_parameters = free_parameters;
  o.parameter_values = parameter_values;
  o.bounds = bounds;
  o.assumed_values = assumed_values;
  o.body_mass = body_mass;
  o.confidence.level = confidence_level;
  o.confidence.bootstrap_samples = bootstrap_samples;
  o.confidence.bootstrap_mode = bootstrap_mode;
  o.confidence.profile = profile;
  o.confidence.seed = seed;
  o.where = {"", 0, "fit_contact_law"};
  if (!(confidence_level > 0 && confidence_level < 1))
    throw InputError({"", 0, "fit_contact_law/confidence_level"}, "expected a level between 0 and 1");
  const std::vector<std::string> names = plugins.is_none() ? std::vector<std::string>{law}
                                                           : plugins.cast<std::vector<std::string>>();
  py::gil_scoped_release release;
  r.registry = std::make_shared<plugin::Registry>();
  for (const std::string& p : names) r.registry->loadPlugin(p, {"", 0, "fit_contact_law/plugins"});
  r.law = std::make_shared<identify::ContactLaw>(
      identify::ContactLaw::fromRegistry(*r.registry, law, {"", 0, "fit_contact_law/law"}));
  r.report = identify::fit(*r.law, data, o);
  return r;
}

}  // namespace

void bindIdentify(py::module_& m) {
  py::class_<FitResult>(m, "FitResult", "A contact law identified from measured forces.")
      .def_property_readonly("law", [](const FitResult& r) { return r.report.law; })
      .def_property_readonly("trials", [](const FitResult& r) { return r.report.trials; })
      .def_property_readonly("parameters", &FitResult::getParameters,
                             "name -> value, unit, status ('identified', 'fixed', 'fixed: not identifiable'), "
                             "value_source, start, bounds, at_bound, ci_asymptotic, ci_profile, ci_bootstrap.")
      .def_property_readonly("derived", &FitResult::getDerived,
                             "Derived quantities (Hertz: K = E/(1-nu^2), K_over_R): value, unit, identified, intervals.")
      .def_property_readonly(
          "values",
          [](const FitResult& r) {
            const Eigen::VectorXd v = r.report.getValues();
            return toArray(std::vector<double>(v.data(), v.data() + v.size()));
          },
          "Every parameter's value, in the law's order.")
      .def_property_readonly("notes", [](const FitResult& r) { return r.report.notes; })
      .def_property_readonly("success", [](const FitResult& r) { return r.report.solver.success; })
      .def_property_readonly("overall", [](const FitResult& r) { return toPython(identify::toJson(r.report.overall)); },
                             "Fit statistics over every frame used (rmse_N, r2, ...).")
      .def("to_dict", [](const FitResult& r) { return toPython(identify::toJson(r.report)); },
           "The whole report as the engine writes it in JSON (identifiability, solver, per trial and phase).")
      .def("predict", &FitResult::predict, py::arg("trial"),
           "The law's force at the identified values on another trial (a dict as for fitting): time, measured, "
           "predicted, metrics.")
      .def("__repr__", [](const FitResult& r) {
        std::string s = "<kneesim.FitResult " + r.report.law + ":";
        for (const auto& q : r.report.derived) s += " " + q.name + " = " + std::to_string(q.value);
        return s + ">";
      });

  m.def("fit_contact_law", &fitContactLaw, py::arg("trials"), py::arg("law") = "hertz", py::arg("plugins") = py::none(),
        py::arg("free_parameters") = std::vector<std::string>{},
        py::arg("parameter_values") = std::map<std::string, double>{},
        py::arg("bounds") = std::map<std::string, std::pair<double, double>>{},
        py::arg("assumed_values") = std::map<std::string, double>{}, py::arg("body_mass") = 0.0,
        py::arg("confidence_level") = 0.95, py::arg("bootstrap_samples") = 200, py::arg("bootstrap_mode") = "frames",
        py::arg("profile") = true, py::arg("seed") = 20150101ULL,
        "Identifies a contact law (a plugin's, default the paper's Hertz law) from trials: dicts with time (s), "
        "channels {name: values} in SI units (Hertz needs 'S', m^2), measured_force (N), and optionally weight "
        "and windows [(begin, end)].");
}

}  // namespace kneesim::python
