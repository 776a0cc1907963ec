// The scene's schema, once: every JSON key of a scene with its type, range or names, default (the Scene field's
// initial value, read from a default-constructed Scene), concern, help text and command-line option, and the rules
// between keys. Scene::fromJson, Scene::validate and Scene::toJson, the command line's scene options
// (cli/SceneOptions) and `voxbrick scene --schema` (which the viewer's test reads) all work from this table.
#pragma once

#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/core/Scene.h"

namespace voxbrick::render {

class TransferFunctionPresets;

/// The struct of Scene a key's field lives in.
enum class SceneConcern { View, Classification, Grid, Mesh, Delivery };
inline constexpr common::EnumName<SceneConcern> kSceneConcernNames[] = {
    {SceneConcern::View, "view"},
    {SceneConcern::Classification, "classification"},
    {SceneConcern::Grid, "grid"},
    {SceneConcern::Mesh, "mesh"},
    {SceneConcern::Delivery, "delivery"}};
constexpr std::span<const common::EnumName<SceneConcern>> enumNames(SceneConcern) { return kSceneConcernNames; }
/// "view", "classification", "grid", "mesh", "delivery".
inline const char* sceneConcernName(SceneConcern concern) { return common::nameOf(concern); }

/// The kinds of dataset a key has an effect on.
enum class SceneApplies { Both, Grids, Meshes };
inline constexpr common::EnumName<SceneApplies> kSceneAppliesNames[] = {
    {SceneApplies::Both, "grids and meshes"}, {SceneApplies::Grids, "grids"}, {SceneApplies::Meshes, "meshes"}};
constexpr std::span<const common::EnumName<SceneApplies>> enumNames(SceneApplies) { return kSceneAppliesNames; }
/// "grids and meshes", "grids", "meshes".
inline const char* sceneAppliesName(SceneApplies applies) { return common::nameOf(applies); }

/// A key's JSON type.
enum class SceneType {
  Object,            ///< "object": a group of keys (camera), each an entry of its own ("camera.fov")
  Bool,              ///< "bool"
  Number,            ///< "number": finite, within SceneKey::range
  Integer,           ///< "integer": a whole number within SceneKey::range
  Name,              ///< "name": one of SceneKey::names
  Text,              ///< "text": a string the key's own parser reads (a quality target)
  Numbers,           ///< "numbers": an array of minCount..maxCount numbers, each within range; or one of names
  TransferFunction,  ///< "transfer_function": a preset name, a file path (command line only) or an inline object
};
/// The names above in quotes.
inline constexpr common::EnumName<SceneType> kSceneTypeNames[] = {
    {SceneType::Object, "object"},   {SceneType::Bool, "bool"},
    {SceneType::Number, "number"},   {SceneType::Integer, "integer"},
    {SceneType::Name, "name"},       {SceneType::Text, "text"},
    {SceneType::Numbers, "numbers"}, {SceneType::TransferFunction, "transfer_function"}};
constexpr std::span<const common::EnumName<SceneType>> enumNames(SceneType) { return kSceneTypeNames; }
inline const char* sceneTypeName(SceneType type) { return common::nameOf(type); }

/// A number's allowed values: [lo, hi] (lo excluded when loOpen), 0 besides when zeroToo, powers of two only when
/// powerOfTwo. Infinite bounds: any finite number.
struct SceneRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool loOpen = false;
  bool zeroToo = false;
  bool powerOfTwo = false;

  bool contains(double v) const;
};

/// When Scene::toJson writes a key.
enum class SceneWritten {
  Always,   ///< whenever the scene has a value for it (orbit for an orbit camera, window when set, ...)
  Changed,  ///< only when its value differs from the default (keys a server of an earlier version may not know)
  Never,    ///< never: a way of giving other keys' values (camera.view, camera.fit)
};

/// What a key's setter needs besides the value: how errors name the key, and where transfer functions come from.
struct SceneSetting {
  std::string name;  ///< the key as errors name it: "scene.json: 'step'", "--step"
  bool allowPaths = true;
  const TransferFunctionPresets* presets = nullptr;
};

/// One scene key.
struct SceneKey {
  std::string key;  ///< "step"; a key of a group is "camera.fov"
  SceneType type = SceneType::Bool;
  SceneConcern concern = SceneConcern::View;
  SceneApplies applies = SceneApplies::Both;
  SceneRange range;                ///< Number, Integer; Numbers: each element
  std::vector<std::string> names;  ///< Name: the values; Numbers: strings accepted instead of numbers ("none")
  int minCount = 0, maxCount = 0;  ///< Numbers: how many
  bool integers = false;           ///< Numbers: whole numbers only
  bool increasing = false;         ///< Numbers: each greater than the one before
  std::string unit;                ///< of the numbers: "voxels", "degrees", ...
  std::string shape;               ///< the JSON form where the type does not say it: "[width, height]"
  std::string help;                ///< one line
  std::string option;              ///< the command-line option that sets it ("--step"), or empty
  std::string optionForm;          ///< the option's value as help shows it ("S", "WxH", "AZ,EL[,DIST]"); empty: a flag
  char separator = ',';            ///< Numbers: between the option's numbers ("10,20", "512x512")
  std::optional<bool> flagValue;   ///< a flag: the value it gives the key (--no-skip: false)
  SceneWritten written = SceneWritten::Always;
  std::string absent;      ///< the default in words where the default scene has no value ("the dataset's value range")
  nlohmann::json example;  ///< a valid value other than the default, for help, tests and errors of Numbers and Text
  /// The key's value in `scene`, null where it has none (window unset; eye for an orbit camera).
  std::function<nlohmann::json(const Scene&)> value;
  /// Sets the key from `v`, which passes checkValue; throws RenderInputError naming `setting.name` for what only
  /// the key's own parser can refuse (an unknown preset, a malformed quality target).
  std::function<void(Scene&, const nlohmann::json&, const SceneSetting&)> set;
  /// The default in words where it is not the value (a transfer function's name); empty: none.
  std::function<std::string(const Scene&)> describe;

  /// What is wrong with `v` as this key's value: empty when it is valid, else "must be ..." (what it may be,
  /// without the value), the words that follow the key's name in an error. `asOption`: in the option's syntax.
  std::string problem(const nlohmann::json& v, bool asOption = false) const;
  /// What follows an error's value `v`: for a name that is not one of `names`, "; did you mean 'NAME'?" with the
  /// closest (common/Names.h); for numbers or a target, "; e.g. EXAMPLE" (in the option's syntax when `asOption`);
  /// else "".
  std::string hint(const nlohmann::json& v, bool asOption = false) const;
  /// What the key may be: "between 0.001 and 64 voxels", "one of \"vertex\", \"cpu\"", "[lo, hi] with hi > lo".
  std::string allowed(bool asOption = false) const;
  /// The value of a default-constructed Scene, or null.
  nlohmann::json defaultValue() const;
  /// The default as help shows it, in the option's syntax where there is one ("0.75", "512x512", "grayscale",
  /// "the dataset's value range").
  std::string defaultText() const;
  /// `v` in the option's syntax: "10,20,3", "vertex", "512x512", "none".
  std::string optionText(const nlohmann::json& v) const;
};

/// Every key, in the order a scene is read and written (a group's keys after the group).
const std::vector<SceneKey>& sceneSchema();
/// The key named `key` ("step", "camera.fov"), or null.
const SceneKey* findSceneKey(const std::string& key);

/// A rule between two keys a and b.
enum class SceneRuleKind {
  Excludes,  ///< a and b are never given together
  Needs,     ///< a is given only with b
  Resets,    ///< a given without b sets b to `value`
};

struct SceneRule {
  SceneRuleKind kind = SceneRuleKind::Excludes;
  std::string a, b;
  /// Laying options over a scene file (layerSceneKeys): a given above drops b below (Excludes: else refused;
  /// Resets: always), and b given above drops a below.
  bool aReplacesB = false, bReplacesA = false;
  nlohmann::json value;  ///< Resets: b's value
  std::string reason;    ///< why, for the error
};

/// Every rule between keys. Scene::toJson writes a of an Excludes pair for both (quality for the settings it
/// chooses).
const std::vector<SceneRule>& sceneRules();

/// A scene's keys, each by its full name ("camera.fov"), with its JSON value.
using SceneKeys = std::map<std::string, nlohmann::json>;

/// How errors name a scene's keys: `prefix` before each message ("scene.json: "), `name` for a key ("'step'",
/// "--step").
struct SceneNames {
  std::string prefix;
  std::function<std::string(const std::string& key)> name;

  /// "WHAT: " and 'KEY', as for a file or a request named `what`.
  static SceneNames of(const std::string& what);
};

/// The keys of the scene JSON object in `text`: refused (RenderInputError naming `what`) when it is not a JSON
/// object, holds a NUL or anything after the object, or has a key the schema does not know.
SceneKeys sceneKeysOf(const std::string& text, const std::string& what);
/// The scene of `keys`: each value checked (SceneKey::problem), the rules applied, then each key set in the
/// schema's order onto a default Scene, which is then validated.
Scene sceneFromKeys(const SceneKeys& keys, const SceneNames& names, bool allowPaths = true,
                    const TransferFunctionPresets* presets = nullptr);
/// `top` laid over `base` (options over a scene file): top's keys replace base's of the same name, and drop those
/// of base their rules say they replace, with the keys of base that need a dropped one; a key of top that excludes
/// one of base it does not replace is refused, naming both as `names` does.
SceneKeys layerSceneKeys(SceneKeys base, const SceneKeys& top, const SceneNames& names);

/// Throws RenderInputError naming the first key whose value in `scene` the schema refuses (Scene::validate).
void checkSceneValues(const Scene& scene);
/// The scene's keys as a JSON object (groups as objects): what Scene::toJson writes.
nlohmann::json sceneJson(const Scene& scene);

/// The schema as JSON, for `voxbrick scene --schema` and the viewer's test: {"keys": [{"key", "type", "concern",
/// "applies", "help", "option", "option_form", "flag_value" (a flag) or "option_allowed" and "option_example",
/// "default", "default_text", "allowed", "min", "max", "min_open", "zero_too", "power_of_two", "names", "count",
/// "integers", "increasing", "unit", "example", "written"}...], "rules": [{"kind", "keys", "a_replaces_b",
/// "b_replaces_a", "value", "reason"}...]}.
nlohmann::json sceneSchemaJson();

}  // namespace voxbrick::render
