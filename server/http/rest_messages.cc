#include "server/http/rest_messages.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "base/echo.h"

namespace skimap::server {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;

const FieldDescriptor* FindField(const Descriptor* d, absl::string_view name) {
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    if (f->name() == name || f->json_name() == name) return f;
  }
  return nullptr;
}

// The numeric leaves of a message type, depth first in declaration order, with their dotted
// JSON names; empty if the type has a leaf of another kind (it has no compact form).
bool NumericLeaves(const Descriptor* d, const std::string& prefix,
                   std::vector<std::vector<const FieldDescriptor*>>* paths,
                   std::vector<const FieldDescriptor*>* stack, std::vector<std::string>* names) {
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    if (f->is_repeated()) return false;
    stack->push_back(f);
    const std::string name = prefix.empty() ? f->json_name() : prefix + "." + f->json_name();
    if (f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
      if (!NumericLeaves(f->message_type(), name, paths, stack, names)) return false;
    } else if (f->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE ||
               f->cpp_type() == FieldDescriptor::CPPTYPE_FLOAT) {
      paths->push_back(*stack);
      names->push_back(name);
    } else {
      return false;
    }
    stack->pop_back();
  }
  return true;
}

// Sets (or adds, for a repeated field) scalar field `f` of `m` from `text`; false if `text`
// is not a value of its type.
bool SetScalar(Message* m, const FieldDescriptor* f, const std::string& text) {
  const Reflection* r = m->GetReflection();
  const bool rep = f->is_repeated();
  switch (f->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE: {
      double v;
      if (!absl::SimpleAtod(text, &v)) return false;
      rep ? r->AddDouble(m, f, v) : r->SetDouble(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_FLOAT: {
      float v;
      if (!absl::SimpleAtof(text, &v)) return false;
      rep ? r->AddFloat(m, f, v) : r->SetFloat(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_INT32: {
      int32_t v;
      if (!absl::SimpleAtoi(text, &v)) return false;
      rep ? r->AddInt32(m, f, v) : r->SetInt32(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_INT64: {
      int64_t v;
      if (!absl::SimpleAtoi(text, &v)) return false;
      rep ? r->AddInt64(m, f, v) : r->SetInt64(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_UINT32: {
      uint32_t v;
      if (!absl::SimpleAtoi(text, &v)) return false;
      rep ? r->AddUInt32(m, f, v) : r->SetUInt32(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_UINT64: {
      uint64_t v;
      if (!absl::SimpleAtoi(text, &v)) return false;
      rep ? r->AddUInt64(m, f, v) : r->SetUInt64(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_BOOL: {
      bool v;
      if (!absl::SimpleAtob(text, &v)) return false;
      rep ? r->AddBool(m, f, v) : r->SetBool(m, f, v);
      return true;
    }
    case FieldDescriptor::CPPTYPE_ENUM: {
      const google::protobuf::EnumValueDescriptor* e = f->enum_type()->FindValueByName(text);
      int number;
      if (e == nullptr && absl::SimpleAtoi(text, &number)) {
        e = f->enum_type()->FindValueByNumber(number);
      }
      if (e == nullptr) return false;
      rep ? r->AddEnum(m, f, e) : r->SetEnum(m, f, e);
      return true;
    }
    case FieldDescriptor::CPPTYPE_STRING: {
      std::string v = text;
      if (f->type() == FieldDescriptor::TYPE_BYTES && !absl::Base64Unescape(text, &v) &&
          !absl::WebSafeBase64Unescape(text, &v)) {
        return false;
      }
      rep ? r->AddString(m, f, std::move(v)) : r->SetString(m, f, std::move(v));
      return true;
    }
    case FieldDescriptor::CPPTYPE_MESSAGE:
      return false;
  }
  return false;
}

std::string TypeName(const FieldDescriptor* f) {
  if (f->cpp_type() == FieldDescriptor::CPPTYPE_ENUM) {
    std::vector<std::string> names;
    for (int i = 0; i < f->enum_type()->value_count(); ++i) {
      names.push_back(f->enum_type()->value(i)->name());
    }
    return absl::StrCat("one of ", absl::StrJoin(names, ", "));
  }
  if (f->cpp_type() == FieldDescriptor::CPPTYPE_BOOL) return "true or false";
  if (f->type() == FieldDescriptor::TYPE_BYTES) return "base64";
  return absl::StrCat("a ", f->cpp_type_name());
}

// The parameters a message takes: its top-level fields' JSON names, minus the path's.
std::string Accepted(const Descriptor* d, const std::set<std::string>& path_fields) {
  std::vector<std::string> names;
  for (int i = 0; i < d->field_count(); ++i) {
    if (path_fields.count(d->field(i)->name()) == 0) names.push_back(d->field(i)->json_name());
  }
  return names.empty() ? "none" : absl::StrJoin(names, ", ");
}

// A parameter's name as it may appear in an error message: as given when it looks like a
// field path, quoted and cut (Echo) otherwise.
std::string ParameterName(const std::string& name) {
  const bool plain =
      name.size() <= kMaxEchoBytes && std::all_of(name.begin(), name.end(), [](char c) {
        return absl::ascii_isalnum(c) || c == '_' || c == '.';
      });
  return plain ? name : Echo(name);
}

absl::Status SetParameter(const std::string& name, const std::vector<std::string>& values,
                          const std::set<std::string>& path_fields, Message* message) {
  auto error = [&name](const std::string& what) {
    return absl::InvalidArgumentError(
        absl::StrCat("query parameter ", ParameterName(name), ": ", what));
  };
  const std::vector<std::string> path = absl::StrSplit(name, '.');
  Message* m = message;
  const FieldDescriptor* f = nullptr;
  for (size_t i = 0; i < path.size(); ++i) {
    f = FindField(m->GetDescriptor(), path[i]);
    if (f == nullptr || (i == 0 && path_fields.count(f->name()) > 0)) {
      return error(absl::StrCat("unknown; this route takes ",
                                Accepted(message->GetDescriptor(), path_fields)));
    }
    if (i + 1 < path.size()) {
      if (f->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || f->is_repeated()) {
        return error(absl::StrCat(path[i], " has no fields"));
      }
      m = m->GetReflection()->MutableMessage(m, f);
    }
  }
  if (f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
    std::vector<std::vector<const FieldDescriptor*>> leaves;
    std::vector<const FieldDescriptor*> stack;
    std::vector<std::string> names;
    if (f->is_repeated() || !NumericLeaves(f->message_type(), "", &leaves, &stack, &names)) {
      return error("cannot be given as a query parameter; send the request's JSON body");
    }
    const std::vector<std::string> numbers = absl::StrSplit(values.back(), ',');
    if (values.size() != 1 || numbers.size() != leaves.size()) {
      return error(absl::StrCat("expected ", leaves.size(), " comma-separated numbers (",
                                absl::StrJoin(names, ","), "), got ", Echo(values.back())));
    }
    Message* target = m->GetReflection()->MutableMessage(m, f);
    for (size_t i = 0; i < leaves.size(); ++i) {
      Message* leaf_owner = target;
      for (size_t k = 0; k + 1 < leaves[i].size(); ++k) {
        leaf_owner = leaf_owner->GetReflection()->MutableMessage(leaf_owner, leaves[i][k]);
      }
      if (!SetScalar(leaf_owner, leaves[i].back(),
                     std::string(absl::StripAsciiWhitespace(numbers[i])))) {
        return error(absl::StrCat(names[i], ": ", Echo(numbers[i]), " is not a number"));
      }
    }
    return absl::OkStatus();
  }
  if (!f->is_repeated() && values.size() > 1) {
    return error(absl::StrCat("given ", values.size(), " times; it takes one value"));
  }
  for (const std::string& value : values) {
    std::vector<std::string> items = {value};
    if (f->is_repeated()) items = absl::StrSplit(value, ',');
    for (const std::string& item : items) {
      if (!SetScalar(m, f, item)) {
        return error(absl::StrCat(Echo(item), " is not ", TypeName(f)));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace

std::string ToJson(const Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  std::string json;
  // Serializing a valid message cannot fail (every field type has a JSON form).
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

absl::Status FromJsonBody(const std::string& body, Message* message) {
  if (absl::StripAsciiWhitespace(body).empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("body: empty; send a JSON ", message->GetDescriptor()->name()));
  }
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(body, message, options);
  if (status.ok()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("body: ", status.message().ToString()));
}

absl::Status FromQueryParameters(const std::multimap<std::string, std::string>& parameters,
                                 const std::set<std::string>& path_fields,
                                 const std::set<std::string>& route_parameters, Message* message) {
  for (auto it = parameters.begin(); it != parameters.end();) {
    const std::string& name = it->first;
    std::vector<std::string> values;
    for (; it != parameters.end() && it->first == name; ++it) values.push_back(it->second);
    if (route_parameters.count(name) > 0) continue;
    if (absl::Status s = SetParameter(name, values, path_fields, message); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status BindPathField(const std::string& field, const std::string& value, Message* message) {
  const FieldDescriptor* f = message->GetDescriptor()->FindFieldByName(field);
  const Reflection* r = message->GetReflection();
  const std::string given = r->GetString(*message, f);
  if (!given.empty() && given != value) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": the body names ", Echo(given), ", the path ", Echo(value)));
  }
  r->SetString(message, f, value);
  return absl::OkStatus();
}

}  // namespace skimap::server
