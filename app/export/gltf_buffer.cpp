#include "export/gltf_buffer.h"

#include <fstream>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion::gltf {

int append_accessor(tinygltf::Model& doc, std::vector<unsigned char>& buffer, const void* bytes, std::size_t byte_count,
                    int component_type, int type, std::size_t count, int target, bool normalized) {
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = byte_count;
  view.target = target;
  const auto* begin = static_cast<const unsigned char*>(bytes);
  if (byte_count) buffer.insert(buffer.end(), begin, begin + byte_count);
  doc.bufferViews.push_back(view);

  tinygltf::Accessor accessor;
  accessor.bufferView = static_cast<int>(doc.bufferViews.size()) - 1;
  accessor.byteOffset = 0;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  accessor.normalized = normalized;
  doc.accessors.push_back(std::move(accessor));
  return static_cast<int>(doc.accessors.size()) - 1;
}

void write_glb(const tinygltf::Model& doc, const std::filesystem::path& path) {
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot open " + tmp.string() + " for writing");
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&doc, out, /*prettyPrint=*/false, /*writeBinary=*/true))
      throw Error("glTF serialisation failed");
    out.close();  // tinygltf does not check its stream: do it here
    if (!out) throw Error("write failed (disk full?)");
  });
}

}  // namespace cofusion::gltf
