-- End-to-end test with a real LSP client: neovim's built-in one (0.7 API).
--
-- Run by lsp/tests/nvim.rs as
--   nvim --headless --clean -c 'luafile tests/lsp/e2e.lua'
-- with MDG_LSP (the server binary), MDG_FILE (the .mdg file to open), MDG_OUT
-- (where to write the results as JSON), MDG_HOVER and MDG_DEFINITION (LSP
-- positions as JSON). It starts the server, opens the file, waits for the
-- diagnostics, asks for hover and definition, stops the server and writes what
-- arrived; it quits with `qall!` on success and `cquit 1` on any failure.

local server = os.getenv('MDG_LSP')
local file = os.getenv('MDG_FILE')
local out = os.getenv('MDG_OUT')

local result = { errors = {} }

local function finish(ok)
  vim.fn.writefile({ vim.fn.json_encode(result) }, out)
  if ok then
    vim.cmd('qall!')
  else
    vim.cmd('cquit 1')
  end
end

local ok, err = pcall(function()
  assert(server and file and out, 'MDG_LSP, MDG_FILE and MDG_OUT must be set')
  local hover_pos = vim.fn.json_decode(os.getenv('MDG_HOVER'))
  local definition_pos = vim.fn.json_decode(os.getenv('MDG_DEFINITION'))

  local published = nil
  local client_id = vim.lsp.start_client({
    name = 'mdg-lsp',
    cmd = { server },
    root_dir = vim.fn.fnamemodify(file, ':p:h'),
    handlers = {
      ['textDocument/publishDiagnostics'] = function(_, params)
        if params and params.diagnostics and #params.diagnostics > 0 then
          published = params
        end
      end,
    },
  })
  assert(client_id, 'vim.lsp.start_client failed')

  vim.cmd('edit ' .. vim.fn.fnameescape(file))
  local bufnr = vim.api.nvim_get_current_buf()
  assert(vim.lsp.buf_attach_client(bufnr, client_id), 'vim.lsp.buf_attach_client failed')

  local started = vim.loop.hrtime()
  assert(vim.wait(10000, function() return published ~= nil end, 5), 'no diagnostics within 10 s')
  result.diagnostics_ms = (vim.loop.hrtime() - started) / 1e6
  result.diagnostics = published

  local uri = vim.uri_from_bufnr(bufnr)
  local function request(method, position)
    local responses = vim.lsp.buf_request_sync(bufnr, method, { textDocument = { uri = uri }, position = position }, 10000)
    assert(responses and responses[client_id], method .. ': no response')
    assert(responses[client_id].err == nil, method .. ': ' .. vim.inspect(responses[client_id].err))
    return responses[client_id].result
  end
  result.hover = request('textDocument/hover', hover_pos)
  result.definition = request('textDocument/definition', definition_pos)

  -- Stop the server the way the editor does (shutdown, exit) and see it go.
  local client = vim.lsp.get_client_by_id(client_id)
  client.stop()
  result.stopped = vim.wait(5000, function() return client.is_stopped() end, 10)
end)

if not ok then
  table.insert(result.errors, tostring(err))
end
finish(ok)
