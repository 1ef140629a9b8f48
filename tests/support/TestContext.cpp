#include "TestContext.h"

namespace penumbra::test {

std::unique_ptr<gpu::Context> makeValidatedContext()
{
    gpu::ContextOptions options = gpu::contextOptionsFromEnvironment({});
    options.validation = true;
    return std::make_unique<gpu::Context>(options);
}

void expectNoValidationMessages(const gpu::Context& context)
{
    EXPECT_TRUE(context.validationEnabled());
    EXPECT_EQ(context.validationMessageCount(), 0u);
    for (const std::string& m : context.validationMessages()) {
        ADD_FAILURE() << "validation: " << m;
    }
}

plugin::PluginRegistry& plugins()
{
    static plugin::PluginRegistry registry;
    return registry;
}

} // namespace penumbra::test
