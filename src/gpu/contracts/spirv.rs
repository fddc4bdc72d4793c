//! Just enough of a SPIR-V reader to see a module's data layouts: names,
//! types, layout decorations, resources, constants and workgroup size.

use std::collections::HashMap;

// Opcodes and enumerants of the SPIR-V 1.5 specification that the reader
// uses (section 3: binary form).
const MAGIC: u32 = 0x0723_0203;
const OP_NAME: u16 = 5;
const OP_MEMBER_NAME: u16 = 6;
const OP_EXECUTION_MODE: u16 = 16;
const OP_TYPE_INT: u16 = 21;
const OP_TYPE_FLOAT: u16 = 22;
const OP_TYPE_VECTOR: u16 = 23;
const OP_TYPE_MATRIX: u16 = 24;
const OP_TYPE_IMAGE: u16 = 25;
const OP_TYPE_ARRAY: u16 = 28;
const OP_TYPE_RUNTIME_ARRAY: u16 = 29;
const OP_TYPE_STRUCT: u16 = 30;
const OP_TYPE_POINTER: u16 = 32;
const OP_CONSTANT: u16 = 43;
const OP_VARIABLE: u16 = 59;
const OP_DECORATE: u16 = 71;
const OP_MEMBER_DECORATE: u16 = 72;
const EXECUTION_MODE_LOCAL_SIZE: u32 = 17;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_MATRIX_STRIDE: u32 = 7;
const DECORATION_LOCATION: u32 = 30;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const DECORATION_OFFSET: u32 = 35;

/// The storage classes a data contract involves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StorageClass {
    /// Images and samplers.
    UniformConstant,
    Input,
    /// Uniform buffers.
    Uniform,
    PushConstant,
    StorageBuffer,
    Other(u32),
}

impl StorageClass {
    fn from_word(word: u32) -> Self {
        match word {
            0 => StorageClass::UniformConstant,
            1 => StorageClass::Input,
            2 => StorageClass::Uniform,
            9 => StorageClass::PushConstant,
            12 => StorageClass::StorageBuffer,
            other => StorageClass::Other(other),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Type {
    Int {
        width: u32,
        signed: bool,
    },
    Float {
        width: u32,
    },
    Vector {
        component: u32,
        count: u32,
    },
    Matrix {
        columns: u32,
    },
    /// `sampled`: 1 for a sampled image, 2 for a storage image.
    Image {
        sampled: u32,
    },
    /// `length`: the id of the constant that holds it.
    Array {
        element: u32,
        length: u32,
    },
    RuntimeArray {
        element: u32,
    },
    Struct {
        members: Vec<u32>,
    },
    Pointer {
        pointee: u32,
    },
}

/// A module-level variable: a resource, a shader input, a push block.
#[derive(Debug, Clone)]
pub struct Variable {
    pub id: u32,
    pub storage: StorageClass,
    /// The type it holds (not its pointer type).
    pub ty: u32,
}

/// One SPIR-V module, indexed by id.
#[derive(Debug, Default)]
pub struct Module {
    pub names: HashMap<u32, String>,
    member_names: HashMap<(u32, u32), String>,
    pub types: HashMap<u32, Type>,
    /// Scalar constants: their first word (integers and 32-bit floats).
    constants: HashMap<u32, u32>,
    pub variables: Vec<Variable>,
    /// (decoration, literal) per id, e.g. (Binding, 3).
    decorations: HashMap<(u32, u32), u32>,
    /// (decoration, literal) per (struct, member), e.g. (Offset, 16).
    member_decorations: HashMap<(u32, u32, u32), u32>,
    pub local_size: Option<[u32; 3]>,
}

impl Module {
    /// Reads a module from its little-endian bytes.
    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() % 4 != 0 || bytes.len() < 20 {
            return Err(format!("{} bytes is not a SPIR-V module", bytes.len()));
        }
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if words[0] != MAGIC {
            return Err(format!("magic number {:#x}, not SPIR-V", words[0]));
        }
        let mut module = Module::default();
        let mut at = 5; // after the header
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            let opcode = (words[at] & 0xffff) as u16;
            if count == 0 || at + count > words.len() {
                return Err(format!("instruction at word {at} runs past the end"));
            }
            module.read_instruction(opcode, &words[at + 1..at + count]);
            at += count;
        }
        Ok(module)
    }

    fn read_instruction(&mut self, opcode: u16, operands: &[u32]) {
        let o = operands;
        match opcode {
            OP_NAME => {
                self.names.insert(o[0], string(&o[1..]));
            }
            OP_MEMBER_NAME => {
                self.member_names.insert((o[0], o[1]), string(&o[2..]));
            }
            OP_EXECUTION_MODE if o[1] == EXECUTION_MODE_LOCAL_SIZE => {
                self.local_size = Some([o[2], o[3], o[4]]);
            }
            OP_DECORATE if o.len() >= 3 => {
                self.decorations.insert((o[0], o[1]), o[2]);
            }
            OP_MEMBER_DECORATE if o.len() >= 4 => {
                self.member_decorations.insert((o[0], o[1], o[2]), o[3]);
            }
            OP_CONSTANT => {
                self.constants.insert(o[1], o[2]);
            }
            OP_VARIABLE => {
                let storage = StorageClass::from_word(o[2]);
                if let Some(Type::Pointer { pointee }) = self.types.get(&o[0]) {
                    let ty = *pointee;
                    self.variables.push(Variable {
                        id: o[1],
                        storage,
                        ty,
                    });
                }
            }
            _ => {
                if let Some(ty) = read_type(opcode, o) {
                    self.types.insert(o[0], ty);
                }
            }
        }
    }

    pub fn name(&self, id: u32) -> Option<&str> {
        self.names.get(&id).map(String::as_str)
    }

    pub fn binding(&self, id: u32) -> Option<u32> {
        self.decorations.get(&(id, DECORATION_BINDING)).copied()
    }

    pub fn descriptor_set(&self, id: u32) -> Option<u32> {
        self.decorations
            .get(&(id, DECORATION_DESCRIPTOR_SET))
            .copied()
    }

    pub fn location(&self, id: u32) -> Option<u32> {
        self.decorations.get(&(id, DECORATION_LOCATION)).copied()
    }

    pub fn array_stride(&self, id: u32) -> Option<u32> {
        self.decorations
            .get(&(id, DECORATION_ARRAY_STRIDE))
            .copied()
    }

    pub fn member_offset(&self, strukt: u32, member: u32) -> Option<u32> {
        self.member_decorations
            .get(&(strukt, member, DECORATION_OFFSET))
            .copied()
    }

    /// The members of struct `id`: (name, type), in order.
    pub fn members(&self, id: u32) -> Vec<(String, u32)> {
        match self.types.get(&id) {
            Some(Type::Struct { members }) => (0..)
                .zip(members)
                .map(|(i, &ty)| {
                    let name = self.member_names.get(&(id, i)).cloned();
                    (name.unwrap_or_else(|| format!("#{i}")), ty)
                })
                .collect(),
            _ => vec![],
        }
    }

    /// Structs named `name` that carry explicit offsets (glslang also
    /// emits an undecorated copy for function-local values).
    pub fn laid_out_structs(&self, name: &str) -> Vec<u32> {
        let mut ids: Vec<u32> = self
            .types
            .iter()
            .filter(|(id, ty)| {
                matches!(ty, Type::Struct { .. })
                    && self.name(**id) == Some(name)
                    && self.member_offset(**id, 0).is_some()
            })
            .map(|(id, _)| *id)
            .collect();
        ids.sort_unstable();
        ids
    }

    /// The number of elements of array type `id`.
    pub fn array_length(&self, id: u32) -> Option<u32> {
        match self.types.get(&id)? {
            Type::Array { length, .. } => self.constants.get(length).copied(),
            Type::Vector { count, .. } => Some(*count),
            _ => None,
        }
    }

    /// The array strides of every array (sized or not) of type `element`.
    pub fn strides_of_arrays_of(&self, element: u32) -> Vec<Option<u32>> {
        let mut arrays: Vec<u32> = self
            .types
            .iter()
            .filter(|(_, ty)| {
                matches!(ty, Type::Array { element: e, .. } | Type::RuntimeArray { element: e }
                    if *e == element)
            })
            .map(|(id, _)| *id)
            .collect();
        arrays.sort_unstable();
        arrays.into_iter().map(|id| self.array_stride(id)).collect()
    }

    /// The bytes that member `member` of struct `strukt` spans, from its
    /// offset to the end of its last element; `None` for a runtime array.
    pub fn member_size(&self, strukt: u32, member: u32) -> Option<u32> {
        let Some(Type::Struct { members }) = self.types.get(&strukt) else {
            return None;
        };
        let ty = *members.get(member as usize)?;
        let matrix_stride = self
            .member_decorations
            .get(&(strukt, member, DECORATION_MATRIX_STRIDE))
            .copied();
        self.size(ty, matrix_stride)
    }

    /// The bytes that a value of type `id` spans, with `matrix_stride`
    /// for matrices (a member decoration of the struct that holds them).
    pub fn size(&self, id: u32, matrix_stride: Option<u32>) -> Option<u32> {
        match self.types.get(&id)? {
            Type::Int { width, .. } | Type::Float { width } => Some(width / 8),
            Type::Vector { component, count } => Some(count * self.size(*component, None)?),
            Type::Matrix { columns, .. } => Some(columns * matrix_stride?),
            Type::Array { .. } => Some(self.array_length(id)? * self.array_stride(id)?),
            Type::Struct { members } => {
                let last = members.len().checked_sub(1)? as u32;
                Some(self.member_offset(id, last)? + self.member_size(id, last)?)
            }
            _ => None,
        }
    }
}

fn read_type(opcode: u16, o: &[u32]) -> Option<Type> {
    Some(match opcode {
        OP_TYPE_INT => Type::Int {
            width: o[1],
            signed: o[2] == 1,
        },
        OP_TYPE_FLOAT => Type::Float { width: o[1] },
        OP_TYPE_VECTOR => Type::Vector {
            component: o[1],
            count: o[2],
        },
        OP_TYPE_MATRIX => Type::Matrix { columns: o[2] },
        OP_TYPE_IMAGE => Type::Image { sampled: o[6] },
        OP_TYPE_ARRAY => Type::Array {
            element: o[1],
            length: o[2],
        },
        OP_TYPE_RUNTIME_ARRAY => Type::RuntimeArray { element: o[1] },
        OP_TYPE_STRUCT => Type::Struct {
            members: o[1..].to_vec(),
        },
        OP_TYPE_POINTER => Type::Pointer { pointee: o[2] },
        // Types no contract looks into (void, bool, samplers, functions).
        _ => return None,
    })
}

/// A literal string: UTF-8, nul-terminated, packed four bytes a word.
fn string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|&b| b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}
